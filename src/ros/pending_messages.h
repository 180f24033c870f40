// Messages waiting in a tf2_ros::MessageFilter for their transform. The filter itself waits without
// bound (a message leaves only when newer ones push it out of the queue); this records when each
// arrived so that the node can skip and count one that waited longer than a timeout, and ignore it
// should the filter deliver it after all. Used from the node's (single-threaded) global queue only.
#pragma once

#include <boost/shared_ptr.hpp>
#include <ros/time.h>

#include <unordered_map>
#include <vector>

namespace octo_slice_mapper {
namespace ros_adapter {

template <typename M>
class PendingMessages {
 public:
  using Ptr = boost::shared_ptr<const M>;

  void arrived(const Ptr& msg, const ros::WallTime& now) { entries_[msg.get()] = {msg, now, false}; }

  // The filter delivered or dropped `msg`. True when it is still to be handled; false when it had
  // timed out already (and was counted then).
  bool resolved(const Ptr& msg) {
    const auto it = entries_.find(msg.get());
    if (it == entries_.end()) return true;
    const bool waiting = !it->second.timed_out;
    entries_.erase(it);
    return waiting;
  }

  // Messages waiting longer than `timeout` for which `still_possible` is false (e.g. their
  // transform is still missing: one that is there now is only waiting its turn in a busy queue),
  // each returned once. They stay recorded (holding the message, so its address can't be reused)
  // until the filter lets go of them.
  template <typename Pred>
  std::vector<Ptr> expire(const ros::WallTime& now, const ros::WallDuration& timeout, Pred still_possible) {
    std::vector<Ptr> expired;
    for (auto& kv : entries_) {
      Entry& e = kv.second;
      if (!e.timed_out && now - e.arrived > timeout && !still_possible(e.msg)) {
        e.timed_out = true;
        expired.push_back(e.msg);
      }
    }
    return expired;
  }

  std::size_t waiting() const {
    std::size_t n = 0;
    for (const auto& kv : entries_) n += kv.second.timed_out ? 0 : 1;
    return n;
  }

 private:
  struct Entry {
    Ptr msg;
    ros::WallTime arrived;
    bool timed_out;
  };
  std::unordered_map<const M*, Entry> entries_;
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
