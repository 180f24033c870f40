#include "ros/pending_messages.h"

#include <gtest/gtest.h>
#include <std_msgs/Header.h>

#include <boost/make_shared.hpp>

using namespace octo_slice_mapper::ros_adapter;

namespace {

// Poses are ints here: the message's seq times 10 when the test's "tf" has it.
using Pending = PendingMessages<std_msgs::Header, int>;
using Ptr = Pending::Ptr;

Ptr message(std::uint32_t seq) {
  auto m = boost::make_shared<std_msgs::Header>();
  m->seq = seq;
  return m;
}

// Messages 1, 2, ... arriving in that order, at the given wall times.
std::vector<Ptr> arriveAt(Pending* p, const std::vector<double>& seconds) {
  std::vector<Ptr> msgs;
  for (double t : seconds) {
    msgs.push_back(message(static_cast<std::uint32_t>(msgs.size() + 1)));
    p->arrived(msgs.back(), ros::WallTime(t));
  }
  return msgs;
}

std::vector<std::uint32_t> seqs(const std::vector<Pending::Ready>& msgs) {
  std::vector<std::uint32_t> out;
  for (const Pending::Ready& r : msgs) out.push_back(r.msg->seq);
  return out;
}

std::vector<std::uint32_t> seqs(const std::vector<Ptr>& msgs) {
  std::vector<std::uint32_t> out;
  for (const Ptr& m : msgs) out.push_back(m->seq);
  return out;
}

int poseOf(const Ptr& m) { return 10 * static_cast<int>(m->seq); }
bool deliver(Pending* p, const Ptr& m) { return p->delivered(m, poseOf(m)); }

// takeReady's pose lookup, from "which messages' transforms are there".
template <typename There>
auto posesIf(There there) {
  return [there](const Ptr& m, int* pose) {
    if (!there(m)) return false;
    *pose = poseOf(m);
    return true;
  };
}
const auto kNoTransform = [](const Ptr&) { return false; };  // tf has no message's transform
const auto kNoPose = posesIf(kNoTransform);
const ros::WallDuration kTimeout(0.5);

}  // namespace

TEST(PendingMessages, InOrderDeliveryIsHandedOutAtOnce) {
  Pending p;
  const ros::WallTime t(100.0);
  const Ptr a = message(1), b = message(2);
  p.arrived(a, t);
  ASSERT_TRUE(deliver(&p, a));
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), std::vector<std::uint32_t>{1});
  p.arrived(b, t);
  ASSERT_TRUE(deliver(&p, b));
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), std::vector<std::uint32_t>{2});
  EXPECT_TRUE(p.takeReady(kNoPose).empty());  // each once
  EXPECT_EQ(p.waiting(), 0u);
  EXPECT_EQ(p.held(), 0u);
}

// Scan 2 (and 3) could go at once; scan 1's transform is still missing (another frame, or tf late).
// Handed on first, they would change the map: clamped updates depend on their order.
TEST(PendingMessages, AnOvertakingMessageWaitsForTheEarlierOne) {
  Pending p;
  const std::vector<Ptr> m = arriveAt(&p, {100.0, 100.0, 100.0});
  const Ptr &a = m[0], &b = m[1], &c = m[2];
  ASSERT_TRUE(deliver(&p, b));
  ASSERT_TRUE(deliver(&p, c));
  EXPECT_TRUE(p.takeReady(kNoPose).empty());
  EXPECT_EQ(p.held(), 2u);
  EXPECT_EQ(p.waiting(), 1u);
  ASSERT_TRUE(deliver(&p, a));
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_EQ(p.held(), 0u);
}

TEST(PendingMessages, ADroppedMessageReleasesTheOnesBehindIt) {
  Pending p;
  const std::vector<Ptr> m = arriveAt(&p, {100.0, 100.0, 100.0});
  const Ptr &a = m[0], &b = m[1], &c = m[2];
  ASSERT_TRUE(deliver(&p, c));
  EXPECT_TRUE(p.dropped(b));  // still to be counted
  EXPECT_TRUE(p.takeReady(kNoPose).empty());  // a still waits
  EXPECT_TRUE(p.dropped(a));
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), std::vector<std::uint32_t>{3});
}

TEST(PendingMessages, ATimedOutMessageHoldsNothingBackAndIsIgnoredLater) {
  Pending p;
  const std::vector<Ptr> m = arriveAt(&p, {100.0, 100.4, 100.4});
  const Ptr &a = m[0], &b = m[1], &c = m[2];
  ASSERT_TRUE(deliver(&p, b));
  EXPECT_TRUE(p.takeReady(kNoPose).empty());
  // Only a has waited longer than the timeout; c has waited long enough but its transform is there.
  EXPECT_EQ(seqs(p.expire(ros::WallTime(100.6), kTimeout, kNoTransform)), std::vector<std::uint32_t>{1});
  EXPECT_TRUE(p.expire(ros::WallTime(101.0), kTimeout, [&](const Ptr& m) { return m == c; }).empty());
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), std::vector<std::uint32_t>{2});  // c still waits, nothing after it
  EXPECT_FALSE(deliver(&p, a));  // counted at its timeout
  ASSERT_TRUE(deliver(&p, c));
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), std::vector<std::uint32_t>{3});
  EXPECT_EQ(p.waiting(), 0u);
}

TEST(PendingMessages, ATimedOutMessageDroppedLaterIsNotCountedTwice) {
  Pending p;
  const Ptr a = message(1);
  p.arrived(a, ros::WallTime(100.0));
  EXPECT_EQ(p.expire(ros::WallTime(101.0), kTimeout, kNoTransform).size(), 1u);
  EXPECT_TRUE(p.expire(ros::WallTime(102.0), kTimeout, kNoTransform).empty());  // each once
  EXPECT_FALSE(p.dropped(a));
  EXPECT_EQ(p.waiting(), 0u);
}

// tf2_ros's MessageFilter can lose a delivery: the transform arrived while it was adding the
// message. The message is taken over once its transform is there, in its turn.
TEST(PendingMessages, AWaitingMessageWhoseTransformIsThereIsTakenOver) {
  Pending p;
  const std::vector<Ptr> m = arriveAt(&p, {100.0, 100.0, 100.0});
  const Ptr &a = m[0], &b = m[1], &c = m[2];
  ASSERT_TRUE(deliver(&p, b));
  std::size_t taken_over = 0;
  // a's transform is there, c's is not (and c holds nothing back: it is the last).
  EXPECT_EQ(seqs(p.takeReady(posesIf([&](const Ptr& m) { return m == a; }), &taken_over)),
            (std::vector<std::uint32_t>{1, 2}));
  EXPECT_EQ(taken_over, 1u);
  EXPECT_EQ(p.waiting(), 1u);
  EXPECT_FALSE(deliver(&p, a)) << "a late delivery of a taken-over message must be ignored";
  EXPECT_TRUE(p.takeReady(kNoPose).empty());
  ASSERT_TRUE(deliver(&p, c));
  EXPECT_EQ(seqs(p.takeReady(kNoPose)), std::vector<std::uint32_t>{3});
}

TEST(PendingMessages, ATakenOverMessageDroppedLaterIsNotCounted) {
  Pending p;
  const Ptr a = message(1);
  p.arrived(a, ros::WallTime(100.0));
  EXPECT_EQ(p.takeReady(posesIf([](const Ptr&) { return true; })).size(), 1u);
  EXPECT_TRUE(p.takeReady(posesIf([](const Ptr&) { return true; })).empty());  // once
  EXPECT_TRUE(p.expire(ros::WallTime(101.0), kTimeout, kNoTransform).empty()) << "handed out, not to time out";
  EXPECT_FALSE(p.dropped(a)) << "pushed out of the filter's queue after it was handled: no skip";
}

// Behind a message whose transform is missing (scans from before the first tf), later ones pile
// up in the tf filter; one the filter lost the delivery of is pushed out of its full queue before
// the block clears. Its transform is there: it is taken over, held, and handed out in its turn,
// not counted as a skip (CI lost 17 scans so).
TEST(PendingMessages, AMessageTakenOverBehindABlockIsKeptWhenTheFilterDropsIt) {
  Pending p;
  const std::vector<Ptr> m = arriveAt(&p, {100.0, 100.1, 100.2, 100.3});
  const Ptr &a = m[0], &b = m[1], &c = m[2], &d = m[3];
  ASSERT_TRUE(deliver(&p, b));
  std::size_t taken_over = 0;
  const auto all_but_a = [&](const Ptr& msg) { return msg != a; };
  EXPECT_TRUE(p.takeReady(posesIf(all_but_a), &taken_over).empty()) << "a holds everything back";
  EXPECT_EQ(taken_over, 2u) << "c and d: their transforms are there";
  EXPECT_EQ(p.waiting(), 1u);
  EXPECT_EQ(p.held(), 3u);
  EXPECT_FALSE(p.dropped(c)) << "taken over: no skip";
  EXPECT_FALSE(deliver(&p, d)) << "taken over: the late delivery is old news";
  EXPECT_TRUE(p.takeReady(posesIf(all_but_a), &taken_over).empty());
  EXPECT_EQ(taken_over, 2u) << "each taken over once";
  EXPECT_EQ(seqs(p.expire(ros::WallTime(101.0), kTimeout, all_but_a)), std::vector<std::uint32_t>{1});
  EXPECT_TRUE(p.expire(ros::WallTime(101.0), kTimeout, kNoTransform).empty()) << "taken over: no time-out";
  EXPECT_EQ(seqs(p.takeReady(posesIf(all_but_a))), (std::vector<std::uint32_t>{2, 3, 4}));
  EXPECT_EQ(p.held(), 0u);
  EXPECT_EQ(p.waiting(), 0u);
}

// A message held back for order keeps the pose it had when its transform was there: tf keeps 10 s
// of data, and at 20x replay the wait for the scans from before the first tf is 10 s (CI lost 17
// scans when their pose was looked up only in their turn).
TEST(PendingMessages, AHeldMessageKeepsThePoseItWasDeliveredOrTakenOverWith) {
  Pending p;
  const std::vector<Ptr> m = arriveAt(&p, {100.0, 100.1, 100.2});
  const Ptr &a = m[0], &b = m[1], &c = m[2];
  ASSERT_TRUE(p.delivered(b, 7));
  EXPECT_TRUE(p.takeReady(posesIf([&](const Ptr& msg) { return msg == c; })).empty());  // c taken over, held
  ASSERT_TRUE(p.dropped(a));
  // By their turn tf has no pose for anyone: each goes with the one it had.
  const auto none = [](const Ptr&, int*) { return false; };
  const std::vector<Pending::Ready> ready = p.takeReady(none);
  ASSERT_EQ(seqs(ready), (std::vector<std::uint32_t>{2, 3}));
  EXPECT_EQ(ready[0].pose, 7);
  EXPECT_EQ(ready[1].pose, poseOf(c));
}
