// Synthetic cameras (synthetic.h): the rendered marker lands where the camera model says, to
// a fraction of a pixel, through the lens distortion; visibility and noise as documented.
#include "biodyn/capture/synthetic.h"

#include <catch2/catch.hpp>

#include "biodyn/capture/blobs.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/random.h"
#include "biodyn/viewer/headless_gl.h"

namespace biodyn::capture {
namespace {

// A free "marker" body with a site, and a box that can hide it.
const char* kMarkerXml = R"(
<mujoco>
  <worldbody>
    <body name="m" pos="0 0 1"><freejoint/><site name="marker" size="0.01"/>
      <geom type="sphere" size="0.001" rgba="0 0 0 0" contype="0" conaffinity="0"/></body>
    <body name="wall" pos="0 0 -5"><freejoint/><geom type="box" size="0.2 0.2 0.2"/></body>
  </worldbody>
</mujoco>)";

void place(const mjModel& m, mjData* d, const Eigen::Vector3d& marker,
           const Eigen::Vector3d& wall) {
  for (int k = 0; k < 3; ++k) {
    d->qpos[k] = marker[k];
    d->qpos[7 + k] = wall[k];
  }
  d->qpos[3] = d->qpos[10] = 1;
  mj_kinematics(&m, d);
}

}  // namespace

TEST_CASE("Synthetic cameras: a rendered marker's centroid is its projection through the lens") {
  viewer::HeadlessGl gl;
  sim::Model model = sim::Model::from_string(kMarkerXml, "marker");
  mjData* d = mj_makeData(model.get());
  SyntheticRigSpec spec;
  spec.cameras = 4;
  spec.jitter_seed = 7;
  const Rig rig = make_synthetic_rig(spec);
  ImageFormation formation;
  formation.sensor_noise_grey = 0;
  const int site = mj_name2id(model.get(), mjOBJ_SITE, "marker");
  SyntheticCameras cameras(*model.get(), rig, {site}, formation);
  BlobDetector detector;
  sim::RandomStream r(sim::stream_key(3, {}));
  double worst = 0, sum2 = 0;
  int seen = 0;
  std::vector<cv::Mat> images;
  std::vector<std::vector<MarkerView>> views;
  for (int trial = 0; trial < 40; ++trial) {
    const Eigen::Vector3d p(1.2 * r.uniform() - 0.6, 1.2 * r.uniform() - 0.6, 2.0 * r.uniform());
    place(*model.get(), d, p, Eigen::Vector3d(0, 0, -5));
    cameras.film(*model.get(), *d, trial, &images, &views);
    for (int c = 0; c < rig.size(); ++c) {
      std::vector<Blob> blobs;
      detector.detect(images[c], &blobs);
      const MarkerView& v = views[c][0];
      REQUIRE(v.visible == rig.cameras[c].in_image(v.uv_px));
      if (!v.visible) {
        CHECK(blobs.empty());
        continue;
      }
      REQUIRE(blobs.size() == 1);
      const double e = (blobs[0].uv_px - v.uv_px).norm();
      worst = std::max(worst, e);
      sum2 += e * e;
      ++seen;
    }
  }
  mj_deleteData(d);
  INFO("markers seen " << seen << ", centroid error RMS " << std::sqrt(sum2 / seen) << " px, worst "
                       << worst << " px");
  CHECK(seen > 100);
  // Measured: RMS 0.07 px, worst 0.19 px (a 25 mm sphere is ~5 px across at 3 m; 8-bit
  // anti-aliased edges and the bilinear lens warp).
  CHECK(std::sqrt(sum2 / seen) < 0.1);
  CHECK(worst < 0.25);
}

TEST_CASE("Synthetic cameras: the body hides a marker, noise moves its image as asked") {
  viewer::HeadlessGl gl;
  sim::Model model = sim::Model::from_string(kMarkerXml, "marker");
  mjData* d = mj_makeData(model.get());
  SyntheticRigSpec spec;
  spec.cameras = 2;
  const Rig rig = make_synthetic_rig(spec);
  const int site = mj_name2id(model.get(), mjOBJ_SITE, "marker");
  std::vector<cv::Mat> images;
  std::vector<std::vector<MarkerView>> views;
  BlobDetector detector;
  std::vector<Blob> blobs;

  SECTION("a box between camera 1 and the marker hides it there only") {
    ImageFormation formation;
    SyntheticCameras cameras(*model.get(), rig, {site}, formation);
    const Eigen::Vector3d p(0, 0, 1);
    const Eigen::Vector3d wall = p + 0.5 * (rig.cameras[0].p_WC - p).normalized();
    place(*model.get(), d, p, wall);
    cameras.film(*model.get(), *d, 0, &images, &views);
    CHECK_FALSE(views[0][0].visible);
    CHECK(views[1][0].visible);
    detector.detect(images[0], &blobs);
    CHECK(blobs.empty());
    detector.detect(images[1], &blobs);
    CHECK(blobs.size() == 1);
  }
  SECTION("0.5 px of centroid noise gives 0.5 px RMS") {
    ImageFormation formation;
    formation.noise_px = 0.5;
    SyntheticCameras cameras(*model.get(), rig, {site}, formation);
    double sum2 = 0;
    int n = 0;
    for (int frame = 0; frame < 100; ++frame) {
      place(*model.get(), d, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, -5));
      cameras.film(*model.get(), *d, frame, &images, &views);
      for (int c = 0; c < 2; ++c) {
        detector.detect(images[c], &blobs);
        REQUIRE(blobs.size() == 1);
        sum2 += (blobs[0].uv_px - views[c][0].uv_px).squaredNorm();
        ++n;
      }
    }
    // Two axes of 0.5 px each: the 2D RMS is 0.5 sqrt(2); 200 samples give it within ~10%.
    CHECK(std::sqrt(sum2 / n) == Approx(0.5 * std::sqrt(2.0)).epsilon(0.15));
  }
  mj_deleteData(d);
}

TEST_CASE("Synthetic rig: every camera sees the whole volume, bad specs are refused") {
  SyntheticRigSpec spec;
  for (int n : {4, 7, 12}) {
    spec.cameras = n;
    spec.jitter_seed = static_cast<std::uint64_t>(n);
    const Rig rig = make_synthetic_rig(spec);
    REQUIRE(rig.size() == n);
    for (const Camera& c : rig.cameras) {
      CHECK(std::abs(std::hypot(c.p_WC.x(), c.p_WC.y()) - spec.distance_m) < 0.31);
      for (double z : {0.0, 1.0, spec.volume_top_m}) {
        for (int k = 0; k < 12; ++k) {
          const double a = 2 * M_PI * k / 12;
          const Eigen::Vector3d p(spec.volume_radius_m * std::cos(a),
                                  spec.volume_radius_m * std::sin(a), z);
          CHECK(c.in_image(c.project(p)));
        }
      }
    }
  }
  spec.cameras = 1;
  CHECK_THROWS_WITH(make_synthetic_rig(spec), Catch::Contains("cameras"));
  spec.cameras = 8;
  spec.k1 = 5;
  CHECK_THROWS_WITH(make_synthetic_rig(spec), Catch::Contains("distortion"));
}

}  // namespace biodyn::capture
