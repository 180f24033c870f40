// Messages that never reached the node, told by gaps in header.seq. ROS drops the oldest message
// of a full subscriber queue without a word (a replay faster than the node, a stalled machine),
// and the node's counters would not show it: inserted + skipped would just fall short.
//
// ROS 1 fills header.seq per publisher (roscpp/rospy count the messages they send; rosbag play
// sends the recorded ones), so a jump forward on one publisher's stream is that many messages
// missed, unless they come later (a bag recorded in another order). A jump back to a seq that was
// not missing is a publisher that started again (a bag replayed with --loop): counting starts
// anew. A stream whose seq stays 0 (nodelets' zero-copy messages) shows no gap.
#pragma once

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <map>
#include <set>
#include <string>

namespace octo_slice_mapper {
namespace ros_adapter {

class SequenceGaps {
 public:
  // Takes one message's seq from `publisher`; returns how many it shows missed before it (0 if
  // none). A message that comes after a later one (a recording in another order) is no longer
  // counted missed when it arrives, and is no restart.
  std::uint64_t add(const std::string& publisher, std::uint32_t seq) {
    const auto [it, first] = streams_.emplace(publisher, Stream{seq, {}});
    if (first) return 0;
    Stream& s = it->second;
    if (seq > s.last) {
      const std::uint32_t gap = seq - s.last - 1;
      for (std::uint32_t k = 1; k <= std::min(gap, kLateWindow); ++k) s.missing.insert(seq - k);
      s.last = seq;
      while (!s.missing.empty() && *s.missing.begin() + kLateWindow < seq) s.missing.erase(s.missing.begin());
      missed_ += gap;
      return gap;
    }
    if (s.missing.erase(seq) > 0) {
      missed_--;  // late, not lost
    } else if (seq < s.last) {
      s = Stream{seq, {}};  // started again
    }
    return 0;
  }
  // Missed so far, over all publishers (a message that comes late is taken back).
  std::uint64_t missed() const { return missed_; }
  // Of them, the ones whose stream has gone kSettle messages past them: surely lost. What a user
  // is warned of (a message recorded after the next one fills its gap at once, and must not be
  // reported as lost even for a moment). All missed but the gaps fewer than kSettle behind their
  // stream's newest message (gaps beyond the late window, and those of a stream that started
  // again, are no longer looked for: lost).
  std::uint64_t settled() const {
    std::uint64_t recent = 0;
    for (const auto& stream : streams_) {
      const Stream& s = stream.second;
      const auto first_recent = s.last < kSettle ? s.missing.begin() : s.missing.upper_bound(s.last - kSettle);
      recent += static_cast<std::uint64_t>(std::distance(first_recent, s.missing.end()));
    }
    return missed_ - recent;
  }

  static constexpr std::uint32_t kSettle = 10;  // messages past a gap (40 Hz: a quarter second)

 private:
  static constexpr std::uint32_t kLateWindow = 1000;  // how far back a late message is looked for
  struct Stream {
    std::uint32_t last;              // the highest seq seen since it (re)started
    std::set<std::uint32_t> missing;  // gaps within kLateWindow of `last`
  };
  std::map<std::string, Stream> streams_;
  std::uint64_t missed_ = 0;
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
