#include "octo_slice_mapper/internal/scan_store.h"

#include <gtest/gtest.h>

#include "test_helpers.h"

using namespace octo_slice_mapper;
using test_support::laserPoseOnRobot;
using test_support::makeScan;

namespace {

Scan scanAt(double x, double yaw, float range = 2.0f) {
  return makeScan(laserPoseOnRobot(x, 0.0, yaw), -1.0f, 0.01f, std::vector<float>(201, range));
}

TEST(ScanStore, KeepsEveryScanByDefaultAndRoundTripsThem) {
  ScanStore store;
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(store.add(scanAt(0.05 * k, 0.0, 1.0f + k)));
  ASSERT_EQ(store.scans().size(), 10u);
  const Scan back = store.scans()[3].toScan();
  EXPECT_FLOAT_EQ(back.ranges[0], 4.0f);
  EXPECT_FLOAT_EQ(back.angle_increment, 0.01f);
  EXPECT_TRUE(back.sensor_pose.isApprox(laserPoseOnRobot(0.15, 0.0, 0.0), 1e-6));
  // 201 floats per scan plus a small header: compact.
  EXPECT_GE(store.memoryBytes(), 10 * 201 * sizeof(float));
  EXPECT_LE(store.memoryBytes(), 10 * (201 * sizeof(float) + 200) + 4096);
}

TEST(ScanStore, KeyframesByDistanceOrRotation) {
  ScanStoreOptions options;
  options.min_distance = 0.5;
  options.min_rotation = 0.3;
  ScanStore store(options);
  EXPECT_TRUE(store.add(scanAt(0.0, 0.0)));
  EXPECT_FALSE(store.add(scanAt(0.2, 0.0))) << "moved too little";
  EXPECT_TRUE(store.add(scanAt(0.6, 0.0))) << "moved far enough";
  EXPECT_FALSE(store.add(scanAt(0.6, 0.2))) << "turned too little";
  EXPECT_TRUE(store.add(scanAt(0.6, 0.4))) << "turned far enough";
  EXPECT_EQ(store.scans().size(), 3u);
  EXPECT_EQ(store.skippedByKeyframe(), 2u);
}

// A robot standing still, or a bag replayed in a loop, adds nothing once its places are kept:
// the store grows with the explored area, not with time.
TEST(ScanStore, SkipsScansFromPlacesAlreadyKept) {
  ScanStore store;
  for (int loop = 0; loop < 5; ++loop) {
    for (int k = 0; k < 20; ++k) store.add(scanAt(0.1 * k, 0.01 * k, 1.0f + loop));
  }
  EXPECT_EQ(store.scans().size(), 20u);
  EXPECT_EQ(store.skippedAsRevisit(), 80u);
  EXPECT_FLOAT_EQ(store.scans().back().ranges[0], 1.0f) << "the first visit is the one kept";
  EXPECT_TRUE(store.add(scanAt(0.0, 0.5))) << "same place, other heading: kept";
  EXPECT_TRUE(store.add(scanAt(0.03, 0.0))) << "a step away: kept";
  ScanStoreOptions off;
  off.revisit_cell = 0.0;
  ScanStore keep_all(off);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(keep_all.add(scanAt(0.0, 0.0)));
}

// Two lidars on one base (or one lidar's beams on two topics): the second one's scan from the
// same place is kept, a repeat of either is not.
TEST(ScanStore, AnotherLidarAtTheSamePlaceIsNoRevisit) {
  ScanStore store;
  const auto pose = laserPoseOnRobot(1.0, 0.0, 0.0);
  const Scan first_half = makeScan(pose, -1.0f, 0.01f, std::vector<float>(100, 2.0f));
  const Scan second_half = makeScan(pose, 0.0f, 0.01f, std::vector<float>(101, 2.0f));
  EXPECT_TRUE(store.add(first_half));
  EXPECT_TRUE(store.add(second_half));
  EXPECT_FALSE(store.add(first_half));
  EXPECT_FALSE(store.add(second_half));
  EXPECT_EQ(store.skippedAsRevisit(), 2u);
}

TEST(ScanStore, BoundedByThinningUniformly) {
  ScanStoreOptions options;
  options.max_scans = 8;
  ScanStore store(options);
  for (int k = 0; k < 20; ++k) store.add(scanAt(0.1 * k, 0.0, 1.0f + k));
  EXPECT_LE(store.scans().size(), 8u);
  EXPECT_EQ(store.scans().size() + store.droppedWhenFull(), 20u);
  // What is kept still spans the whole run: first and last scans are there, in order.
  EXPECT_FLOAT_EQ(store.scans().front().ranges[0], 1.0f);
  EXPECT_FLOAT_EQ(store.scans().back().ranges[0], 20.0f);
  for (std::size_t i = 1; i < store.scans().size(); ++i) {
    EXPECT_LT(store.scans()[i - 1].ranges[0], store.scans()[i].ranges[0]);
  }
}

}  // namespace
