// Messages between their arrival and their turn to be handled, for a tf2_ros::MessageFilter.
//
// Two things the filter does not do:
// - Time out. It waits without bound (a message leaves only when newer ones push it out of its
//   queue); this records when each arrived so that the node can skip and count one that waited
//   longer than a timeout, and ignore it should the filter deliver it after all.
// - Keep order. A message that waited for its transform is handed on from tf's thread and can be
//   overtaken by the next one, whose transform was already there when it arrived. Updates clamp,
//   so the order changes the map: a delivered message is held here until every one that arrived
//   before it has been delivered, dropped or timed out, and handed out in arrival order.
//
// Used from the node's (single-threaded) global queue only.
#pragma once

#include <boost/shared_ptr.hpp>
#include <ros/time.h>

#include <cstdint>
#include <map>
#include <unordered_map>
#include <vector>

namespace octo_slice_mapper {
namespace ros_adapter {

template <typename M>
class PendingMessages {
 public:
  using Ptr = boost::shared_ptr<const M>;

  void arrived(const Ptr& msg, const ros::WallTime& now) {
    const auto old = order_.find(msg.get());
    if (old != order_.end()) entries_.erase(old->second);  // the same message twice: its later arrival counts
    order_[msg.get()] = next_;
    entries_[next_++] = {msg, now, State::kWaiting};
  }

  // The filter delivered `msg`. False when it had timed out already (and was counted then): ignore
  // it. Otherwise it is ready, and takeReady() hands it out in its turn.
  bool delivered(const Ptr& msg) {
    Entry* e = find(msg);
    if (!e) return true;  // not seen arriving (can't happen with the subscriber registered first)
    if (e->state == State::kTimedOut) {
      forget(msg);
      return false;
    }
    e->state = State::kReady;
    return true;
  }

  // The filter dropped `msg`. True when it is still to be counted; false when it had timed out
  // already (and was counted then). Either way, it no longer holds later messages back.
  bool dropped(const Ptr& msg) {
    const Entry* e = find(msg);
    const bool waiting = !e || e->state == State::kWaiting;
    forget(msg);
    return waiting;
  }

  // Delivered messages with no earlier one still waiting for the filter, oldest arrival first;
  // each returned once.
  std::vector<Ptr> takeReady() {
    std::vector<Ptr> ready;
    for (auto it = entries_.begin(); it != entries_.end();) {
      if (it->second.state == State::kWaiting) break;
      if (it->second.state == State::kReady) {
        ready.push_back(it->second.msg);
        order_.erase(it->second.msg.get());
        it = entries_.erase(it);
      } else {
        ++it;  // timed out: holds nothing back, stays until the filter lets go of it
      }
    }
    return ready;
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
      if (e.state == State::kWaiting && now - e.arrived > timeout && !still_possible(e.msg)) {
        e.state = State::kTimedOut;
        expired.push_back(e.msg);
      }
    }
    return expired;
  }

  // Still waiting for the filter.
  std::size_t waiting() const { return count(State::kWaiting); }
  // Delivered, but held back behind an earlier one.
  std::size_t held() const { return count(State::kReady); }

 private:
  enum class State { kWaiting, kReady, kTimedOut };
  struct Entry {
    Ptr msg;
    ros::WallTime arrived;
    State state;
  };

  Entry* find(const Ptr& msg) {
    const auto it = order_.find(msg.get());
    return it == order_.end() ? nullptr : &entries_.at(it->second);
  }
  void forget(const Ptr& msg) {
    const auto it = order_.find(msg.get());
    if (it == order_.end()) return;
    entries_.erase(it->second);
    order_.erase(it);
  }
  std::size_t count(State state) const {
    std::size_t n = 0;
    for (const auto& kv : entries_) n += kv.second.state == state ? 1 : 0;
    return n;
  }

  std::uint64_t next_ = 0;
  std::map<std::uint64_t, Entry> entries_;           // by arrival
  std::unordered_map<const M*, std::uint64_t> order_;  // message -> its arrival number
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
