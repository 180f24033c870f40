#include "ros/sequence_gaps.h"

#include <gtest/gtest.h>

using octo_slice_mapper::ros_adapter::SequenceGaps;

TEST(SequenceGaps, AnUnbrokenStreamMissesNothing) {
  SequenceGaps gaps;
  for (std::uint32_t s = 40; s < 60; ++s) EXPECT_EQ(gaps.add("/urg_node", s), 0u);
  EXPECT_EQ(gaps.missed(), 0u) << "a stream joined at seq 40 has missed nothing";
}

TEST(SequenceGaps, AJumpForwardIsThatManyMessagesMissed) {
  SequenceGaps gaps;
  gaps.add("/play", 0);
  gaps.add("/play", 1);
  EXPECT_EQ(gaps.add("/play", 5), 3u);  // 2, 3, 4 dropped by a full queue
  gaps.add("/play", 6);
  EXPECT_EQ(gaps.add("/play", 8), 1u);
  EXPECT_EQ(gaps.missed(), 4u);
}

TEST(SequenceGaps, EachPublisherIsItsOwnStream) {
  SequenceGaps gaps;
  gaps.add("/front", 10);
  gaps.add("/rear", 500);
  EXPECT_EQ(gaps.add("/front", 11), 0u);
  EXPECT_EQ(gaps.add("/rear", 501), 0u);
  EXPECT_EQ(gaps.missed(), 0u) << "two lidars' seqs interleaved are no gap";
}

TEST(SequenceGaps, APublisherStartingAgainIsNoGap) {
  SequenceGaps gaps;
  for (std::uint32_t s = 0; s < 100; ++s) gaps.add("/play", s);
  EXPECT_EQ(gaps.add("/play", 0), 0u);  // rosbag play --loop
  EXPECT_EQ(gaps.add("/play", 1), 0u);
  EXPECT_EQ(gaps.add("/play", 3), 1u) << "counted anew after the restart";
  EXPECT_EQ(gaps.missed(), 1u);
}

TEST(SequenceGaps, SeqLeftAtZeroShowsNoGap) {
  SequenceGaps gaps;
  for (int k = 0; k < 10; ++k) EXPECT_EQ(gaps.add("/nodelet_manager", 0), 0u);
  EXPECT_EQ(gaps.missed(), 0u);
}

// simulate_session's real-robot bag records four scans after the one that follows them.
TEST(SequenceGaps, AMessageRecordedAfterTheNextOneIsNotMissed) {
  SequenceGaps gaps;
  gaps.add("/play", 3);
  EXPECT_EQ(gaps.add("/play", 5), 1u);  // 4 not there yet
  EXPECT_EQ(gaps.missed(), 1u);
  EXPECT_EQ(gaps.add("/play", 4), 0u);
  EXPECT_EQ(gaps.missed(), 0u) << "4 came late, it was not lost";
  EXPECT_EQ(gaps.add("/play", 6), 0u) << "and it was no restart";
  EXPECT_EQ(gaps.missed(), 0u);
}

TEST(SequenceGaps, AMessageLaterThanTheWindowIsARestart) {
  SequenceGaps gaps;
  gaps.add("/play", 0);
  gaps.add("/play", 5000);  // 4999 missed; only the last 1000 are looked for
  EXPECT_EQ(gaps.missed(), 4999u);
  gaps.add("/play", 4500);  // missing, within the window: late
  EXPECT_EQ(gaps.missed(), 4998u);
  gaps.add("/play", 10);  // not looked for: a restart, counting anew
  EXPECT_EQ(gaps.add("/play", 12), 1u);
  EXPECT_EQ(gaps.missed(), 4999u);
}

// What the node warns of: a gap counts as lost only once its stream is SequenceGaps::kSettle
// messages past it, so a scan recorded after the next one is never reported lost, not even for
// the moment between the two (the node's warning once came at each gap as it was seen).
TEST(SequenceGaps, AGapIsLostOnlyOnceItsStreamHasGoneOnPastIt) {
  SequenceGaps gaps;
  gaps.add("/play", 0);
  gaps.add("/play", 2);  // 1 not there yet
  EXPECT_EQ(gaps.missed(), 1u);
  EXPECT_EQ(gaps.settled(), 0u) << "it may come late";
  gaps.add("/play", 1);
  for (std::uint32_t s = 3; s < 40; ++s) gaps.add("/play", s);
  EXPECT_EQ(gaps.missed(), 0u);
  EXPECT_EQ(gaps.settled(), 0u) << "it came: never lost";

  gaps.add("/play", 45);  // 40..44 dropped by a full queue
  EXPECT_EQ(gaps.missed(), 5u);
  EXPECT_EQ(gaps.settled(), 0u);
  for (std::uint32_t s = 46; s <= 40 + SequenceGaps::kSettle; ++s) gaps.add("/play", s);
  EXPECT_EQ(gaps.settled(), 1u) << "40 is kSettle behind now, 41..44 are not yet";
  for (std::uint32_t s = 41 + SequenceGaps::kSettle; s <= 44 + SequenceGaps::kSettle; ++s) gaps.add("/play", s);
  EXPECT_EQ(gaps.settled(), 5u);
  EXPECT_EQ(gaps.missed(), 5u);
  gaps.add("/play", 42);  // later than anyone waits for, but it came
  EXPECT_EQ(gaps.missed(), 4u);
  EXPECT_EQ(gaps.settled(), 4u);
}

TEST(SequenceGaps, GapsBeyondTheWindowAndBeforeARestartAreLost) {
  SequenceGaps gaps;
  gaps.add("/play", 0);
  gaps.add("/play", 5000);  // 4999 missed; the 3999 not looked for are lost at once
  EXPECT_EQ(gaps.settled(), 4999u - 1000u + 1000u - (SequenceGaps::kSettle - 1))
      << "the last kSettle - 1 of the window may still come";
  gaps.add("/play", 7);  // a restart: what the old stream still waited for is lost
  EXPECT_EQ(gaps.settled(), 4999u);
  EXPECT_EQ(gaps.missed(), 4999u);
}
