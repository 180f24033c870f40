// Depth frames prepared on several threads and applied in order (CloudPipeline): the
// map is the one of inserting the same scans and clouds one by one, whatever the threads do.
#include "octo_slice_mapper/cloud_pipeline.h"

#include <gtest/gtest.h>

#include <atomic>
#include <random>
#include <stdexcept>
#include <vector>

#include "octo_slice_mapper/sim/depth_camera.h"
#include "octo_slice_mapper/sim/session.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;
using test_support::expectSameTree;

namespace {

// Camera frames of the simulated office room (a small camera, so that the test is quick), in
// the map frame, from poses along a path, and the lidar's scans of the office tour.
class CloudPipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim::DepthCameraSpec spec;
    spec.width = 160;
    spec.height = 120;
    std::mt19937 rng(7);
    clouds_ = new std::vector<SensorCloud>();
    for (int k = 0; k < 12; ++k) {
      const Eigen::Isometry3d pose =
          sim::opticalPose(Eigen::Vector3d(0.5 + 0.3 * k, 0.6 + 0.2 * k, 0.30), 0.6 + 0.1 * k, 0.05);
      SensorCloud cloud;
      cloud.origin = pose.translation();
      for (const Eigen::Vector3f& p : sim::depthFrame(sim::BoxScene::officeRoom(), pose, spec, &rng)) {
        cloud.points.push_back(p.allFinite() ? Eigen::Vector3f((pose * p.cast<double>()).cast<float>()) : p);
      }
      clouds_->push_back(std::move(cloud));
    }
    const sim::SimulatedSession office(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
    const std::vector<Scan> all = office.allScans();
    scans_ = new std::vector<Scan>(all.begin(), all.begin() + 36);
  }
  static void TearDownTestSuite() {
    delete clouds_;
    delete scans_;
  }
  static MapperOptions options() {
    MapperOptions o;
    o.slice.min_z = 0.05;  // the navigation band: the frames' obstacles show in the slice
    o.slice.max_z = 0.80;
    return o;
  }
  // The input in one order: three scans, then a cloud, and so on.
  template <typename OnScan, typename OnCloud>
  static void forEachInput(OnScan&& on_scan, OnCloud&& on_cloud) {
    for (std::size_t k = 0; k < clouds_->size(); ++k) {
      for (std::size_t s = 3 * k; s < 3 * k + 3; ++s) on_scan((*scans_)[s]);
      on_cloud((*clouds_)[k]);
    }
  }
  static std::vector<SensorCloud>* clouds_;
  static std::vector<Scan>* scans_;
};
std::vector<SensorCloud>* CloudPipelineTest::clouds_ = nullptr;
std::vector<Scan>* CloudPipelineTest::scans_ = nullptr;

TEST_F(CloudPipelineTest, GivesTheMapOfInsertingOneByOneInTheOrderSubmitted) {
  MappingSession one_by_one(options(), SessionOptions{});
  forEachInput([&](const Scan& scan) { ASSERT_TRUE(one_by_one.insert(scan).ok()); },
               [&](const SensorCloud& cloud) { ASSERT_TRUE(one_by_one.insert(cloud).ok()); });
  for (unsigned threads : {1u, 2u, 3u}) {
    MappingSession session(options(), SessionOptions{});
    std::vector<int> order;  // the Done callbacks: 0 for a scan, 1 for a cloud
    std::atomic<int> failed{0};
    {
      CloudPipeline pipeline(&session, threads, 2 * threads);
      EXPECT_EQ(pipeline.threads(), threads);
      const auto done = [&](int kind) {
        return [&, kind](const CloudPipeline::Outcome& o) {
          order.push_back(kind);
          if (!o.result.ok()) failed++;
        };
      };
      // Every other cloud as the node hands it on: its points made on the worker.
      std::size_t clouds = 0;
      forEachInput([&](const Scan& scan) { pipeline.submit(scan, done(0)); },
                   [&](const SensorCloud& cloud) {
                     if (clouds++ % 2 == 0) {
                       pipeline.submit(cloud, done(1));
                       return;
                     }
                     DeferredCloud deferred;
                     deferred.origin = cloud.origin;
                     deferred.points = [&cloud](std::vector<Eigen::Vector3f>* points, ReadingCounts*, const FlyingPixelOptions&) {
                       *points = cloud.points;
                     };
                     pipeline.submit(std::move(deferred), done(1));
                   });
      pipeline.wait();
      EXPECT_GT(pipeline.memoryBytes(), 0u);
    }
    EXPECT_EQ(failed.load(), 0);
    std::vector<int> expected;
    forEachInput([&](const Scan&) { expected.push_back(0); }, [&](const SensorCloud&) { expected.push_back(1); });
    EXPECT_EQ(order, expected) << threads << " threads";
    session.withMapper([&](Mapper& m) {
      one_by_one.withMapper([&](Mapper& reference) {
        expectSameTree(reference.tree(), m.tree());
        // The floor layer took the frames in their order too (each frame is measured against it).
        EXPECT_EQ(m.floor().status().frames_found, reference.floor().status().frames_found);
        EXPECT_EQ(m.floor().status().cells, reference.floor().status().cells);
        // The slice followed the floor at the same frames: the same raster, cell for cell (a
        // frame took the level changes of whichever later frames were already folded in, and
        // the grid grew to other bounds from run to run).
        const GridImage slice = gridImageOf(m.slice()), expected_slice = gridImageOf(reference.slice());
        EXPECT_EQ(slice.width, expected_slice.width) << threads << " threads";
        EXPECT_EQ(slice.height, expected_slice.height) << threads << " threads";
        EXPECT_EQ(slice.origin_x, expected_slice.origin_x) << threads << " threads";
        EXPECT_EQ(slice.origin_y, expected_slice.origin_y) << threads << " threads";
        EXPECT_TRUE(slice.cells == expected_slice.cells) << threads << " threads";
      });
      EXPECT_GT(m.floor().status().frames_found, clouds_->size() / 2) << "the frames' floor was not found";
      EXPECT_EQ(m.stats().clouds_inserted, clouds_->size());
      EXPECT_EQ(m.stats().scans_inserted, scans_->size());
    });
  }
}

// The destructor applies what was submitted; a refused cloud (its origin outside the octree, or
// its points not made: the conversion threw) is reported in its turn and the ones after it still
// go in.
TEST_F(CloudPipelineTest, ARefusedCloudLosesNothingElseAndTheDestructorAppliesTheRest) {
  MappingSession session(options(), SessionOptions{});
  std::vector<std::string> errors;
  {
    CloudPipeline pipeline(&session, 2, 2);
    const auto record = [&](const CloudPipeline::Outcome& o) { errors.push_back(o.result.error); };
    SensorCloud outside = (*clouds_)[0];
    outside.origin = Eigen::Vector3d(1e7, 0.0, 0.0);  // beyond the octree's keys
    DeferredCloud unmade;
    unmade.origin = (*clouds_)[0].origin;
    unmade.points = [](std::vector<Eigen::Vector3f>*, ReadingCounts*, const FlyingPixelOptions&) {
      throw std::runtime_error("conversion failed");
    };
    pipeline.submit((*clouds_)[0], record);
    pipeline.submit(outside, record);
    pipeline.submit(std::move(unmade), record);
    for (std::size_t k = 1; k < clouds_->size(); ++k) pipeline.submit((*clouds_)[k], record);
  }  // no wait(): the destructor's
  ASSERT_EQ(errors.size(), clouds_->size() + 2);
  for (std::size_t k = 0; k < errors.size(); ++k) {
    EXPECT_EQ(errors[k].empty(), k != 1 && k != 2) << k << ": " << errors[k];
  }
  EXPECT_NE(errors[2].find("conversion failed"), std::string::npos) << errors[2];
  session.withMapper([&](Mapper& m) { EXPECT_EQ(m.stats().clouds_inserted, clouds_->size()); });
}

// A reset between frames: the workers' preparers follow the new map (made anew), and what comes
// after is the map of those frames alone.
TEST_F(CloudPipelineTest, AfterAResetTheFramesGoIntoTheNewMap) {
  MappingSession session(options(), SessionOptions{});
  MappingSession fresh(options(), SessionOptions{});
  CloudPipeline pipeline(&session, 2, 4);
  for (std::size_t k = 0; k < 6; ++k) pipeline.submit((*clouds_)[k]);
  pipeline.wait();
  session.reset();
  for (std::size_t k = 6; k < clouds_->size(); ++k) {
    pipeline.submit((*clouds_)[k]);
    ASSERT_TRUE(fresh.insert((*clouds_)[k]).ok());
  }
  pipeline.wait();
  session.withMapper([&](Mapper& m) {
    fresh.withMapper([&](Mapper& reference) { expectSameTree(reference.tree(), m.tree()); });
  });
}

// submit() waits while max_pending jobs are not yet applied: frames in flight stay bounded.
TEST_F(CloudPipelineTest, HoldsAtMostMaxPendingJobs) {
  MappingSession session(options(), SessionOptions{});
  std::atomic<int> submitted{0}, applied{0}, most{0};
  {
    CloudPipeline pipeline(&session, 2, 3);
    for (const SensorCloud& cloud : *clouds_) {
      pipeline.submit(cloud, [&](const CloudPipeline::Outcome&) {
        // Counted before applied is: jobs submitted and not yet applied, this one included.
        const int pending = submitted.load() - applied.load();
        most = std::max(most.load(), pending);
        applied++;
      });
      submitted++;
    }
  }
  EXPECT_EQ(applied.load(), static_cast<int>(clouds_->size()));
  EXPECT_LE(most.load(), 3);
  EXPECT_GE(most.load(), 1);
}

}  // namespace
