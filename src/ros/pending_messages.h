// Messages between their arrival and their turn to be handled, for a tf2_ros::MessageFilter.
//
// Three things the filter does not do:
// - Time out. It waits without bound (a message leaves only when newer ones push it out of its
//   queue); this records when each arrived so that the node can skip and count one that waited
//   longer than a timeout, and ignore it should the filter deliver it after all.
// - Keep order. A message that waited for its transform is handed on from tf's thread and can be
//   overtaken by the next one, whose transform was already there when it arrived. Updates clamp,
//   so the order changes the map: messages are handed out here in arrival order.
// - Always deliver. If the transform arrives while the filter is still adding the message, tf2
//   fires the filter's request before the filter has recorded the message, and the message stays
//   in its queue until pushed out (seen replaying Radish logs: 1 scan in a few hundred). So a
//   waiting message whose transform is there is taken over: handed out as if delivered, and its
//   delivery, should it come after all, ignored.
// - Keep the transform. A message held back for order can wait longer than tf keeps data (10 s of
//   stamps; at 20x replay a 0.5 s wait is 10 s): its pose is therefore taken when its transform is
//   known to be there (delivered or taken over) and kept with it (CI lost 17 scans held behind
//   the scans from before the first tf, their tf data dropped by the time their turn came).
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

template <typename M, typename Pose>
class PendingMessages {
 public:
  using Ptr = boost::shared_ptr<const M>;
  struct Ready {
    Ptr msg;
    Pose pose;  // the sensor's pose at the message's stamp
  };

  // Each message once: a recorded one is held on to, so no new message can have its address.
  void arrived(const Ptr& msg, const ros::WallTime& now) {
    order_[msg.get()] = next_;
    entries_[next_++] = {msg, now, State::kWaiting};
  }

  // The filter delivered `msg`, whose pose is `pose`. False when that is old news: it timed out
  // (and was counted then) or was taken over. Otherwise takeReady() hands it out in its turn.
  bool delivered(const Ptr& msg, const Pose& pose) { return letGo(msg, &pose); }

  // The filter dropped `msg`. True when it is to be counted as skipped; false when it timed out
  // (counted then) or was taken over (then still handed out in its turn). Either way, it no longer
  // holds later messages back.
  bool dropped(const Ptr& msg) { return letGo(msg, nullptr); }

  // The messages to handle now with their poses, oldest arrival first, each returned once: those
  // the filter delivered and those still waiting whose pose is there (`pose_of(msg, &pose)` is
  // true), up to the first one whose pose is missing. A waiting message behind that one whose pose
  // is there is taken over all the same, and held: the filter may push it out of its full queue
  // before its turn. `taken_over` (if given) counts the messages taken over.
  template <typename PoseOf>
  std::vector<Ready> takeReady(PoseOf pose_of, std::size_t* taken_over = nullptr) {
    std::vector<Ready> ready;
    bool blocked = false;
    for (auto it = entries_.begin(); it != entries_.end();) {
      Entry& e = it->second;
      if (e.state == State::kWaiting) {
        if (!pose_of(e.msg, &e.pose)) {
          blocked = true;
          ++it;
          continue;
        }
        e.state = State::kTakenOver;
        if (taken_over) ++*taken_over;
      }
      if (blocked || (e.state != State::kTakenOver && e.state != State::kReady)) {
        ++it;  // held back; or timed out or handed out, still in the filter: holds nothing back
      } else if (e.state == State::kTakenOver) {
        ready.push_back({e.msg, e.pose});
        e.state = State::kHandedOut;  // kept until the filter lets go of it
        ++it;
      } else {
        ready.push_back({e.msg, e.pose});
        order_.erase(e.msg.get());
        it = entries_.erase(it);
      }
    }
    return ready;
  }

  // Messages waiting longer than `timeout` for which `still_possible` is false (their transform
  // is still missing; one whose transform is there is takeReady's), each returned once. They stay
  // recorded (holding the message, so its address can't be reused) until the filter lets go of
  // them.
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
  // Ready, but held back behind an earlier one whose transform is missing.
  std::size_t held() const { return count(State::kReady) + count(State::kTakenOver); }

 private:
  // kWaiting: in the filter; kReady: delivered, to be handed out; kTakenOver: its transform is
  // there, still in the filter, to be handed out; kTimedOut: given up (and counted), still in the
  // filter; kHandedOut: taken over and handed out, still in the filter.
  enum class State { kWaiting, kReady, kTakenOver, kTimedOut, kHandedOut };
  struct Entry {
    Ptr msg;
    ros::WallTime arrived;
    State state;
    Pose pose{};  // set when delivered or taken over
  };

  // The filter delivered `msg` (with its pose) or dropped it (`pose` null). True when that is news
  // (a waiting message): a delivery to hand out, or a drop to count.
  bool letGo(const Ptr& msg, const Pose* pose) {
    const auto found = order_.find(msg.get());
    if (found == order_.end()) return pose != nullptr;  // not seen arriving: can't happen
    Entry& e = entries_.find(found->second)->second;
    const bool news = e.state == State::kWaiting;
    if (news && pose) {
      e.state = State::kReady;
      e.pose = *pose;
    } else if (e.state == State::kTakenOver) {
      e.state = State::kReady;  // out of the filter, still to be handed out with the pose it has
    } else if (e.state != State::kReady) {  // (a second word on a delivered one: ignored)
      entries_.erase(found->second);
      order_.erase(found);
    }
    return news;
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
