// Camera model and rig files (camera.h).
#include "biodyn/capture/camera.h"

#include <catch2/catch.hpp>

#include "biodyn/sim/errors.h"

namespace biodyn::capture {
namespace {

Camera test_camera() {
  Camera c;
  c.name = "cam01";
  c.K.fx_px = 610;
  c.K.fy_px = 605;
  c.K.cx_px = 330.2;
  c.K.cy_px = 241.7;
  c.K.k1 = -0.12;
  c.K.k2 = 0.05;
  c.K.p1 = 0.001;
  c.K.p2 = -0.0007;
  c.K.k3 = -0.01;
  c.p_WC = Eigen::Vector3d(3, 0.5, 2);
  c.R_CW = look_at(c.p_WC, Eigen::Vector3d(0, 0, 1));
  return c;
}

}  // namespace

TEST_CASE("Camera: projection, its inverse and the pinhole matrix agree") {
  const Camera c = test_camera();
  // The camera looks at the target: it lands on the principal point (no distortion there).
  const Eigen::Vector2d centre = c.project(Eigen::Vector3d(0, 0, 1));
  CHECK((centre - Eigen::Vector2d(c.K.cx_px, c.K.cy_px)).norm() < 1e-9);
  // Up in the world is up in the image (v decreases).
  CHECK(c.project(Eigen::Vector3d(0, 0, 1.5)).y() < centre.y());
  for (int u = 0; u < c.K.width_px; u += 37) {
    for (int v = 0; v < c.K.height_px; v += 29) {
      const Eigen::Vector2d px(u, v);
      const Eigen::Vector3d p_W = c.p_WC + 2.5 * c.ray_W(px);
      CHECK((c.project(p_W) - px).norm() < 1e-6);
      // Without distortion, the 3 x 4 matrix gives the pinhole pixel.
      const Eigen::Vector3d h = c.projection_matrix() * p_W.homogeneous();
      CHECK((h.hnormalized() - c.project_pinhole(p_W)).norm() < 1e-9);
    }
  }
  bool in_front = true;
  c.project(Eigen::Vector3d(6, 1, 3), &in_front);
  CHECK_FALSE(in_front);
}

TEST_CASE("Rig files: a round trip is exact, bad files name the field") {
  Rig rig;
  rig.source = "test";
  rig.cameras = {test_camera(), test_camera()};
  rig.cameras[1].name = "cam02";
  rig.reprojection_rms_px = {0.11, 0.12};
  const Rig back = parse_rig_json(format_rig_json(rig), "rig.json");
  REQUIRE(back.size() == 2);
  CHECK(back.cameras[1].name == "cam02");
  CHECK(back.cameras[0].K.k3 == rig.cameras[0].K.k3);
  CHECK((back.cameras[0].R_CW - rig.cameras[0].R_CW).norm() == 0);
  CHECK(back.cameras[0].p_WC == rig.cameras[0].p_WC);
  CHECK(back.reprojection_rms_px == rig.reprojection_rms_px);
  CHECK(back.find("cam02") == 1);

  const std::string good = format_rig_json(rig);
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const std::size_t at = s.find(from);
    REQUIRE(at != std::string::npos);
    s.replace(at, from.size(), to);
    return s;
  };
  CHECK_THROWS_WITH(parse_rig_json("{", "rig.json"),
                    Catch::Contains("rig.json") && Catch::Contains("malformed"));
  CHECK_THROWS_WITH(parse_rig_json(with("\"fx_px\": 610", "\"fx_px\": 1e400"), "rig.json"),
                    Catch::Contains("rig.json") && Catch::Contains("malformed"));
  CHECK_THROWS_WITH(parse_rig_json(with("\"fx_px\": 610", "\"fx_px\": -1"), "rig.json"),
                    Catch::Contains("cameras[0]") && Catch::Contains("fx_px"));
  CHECK_THROWS_WITH(parse_rig_json(with("\"name\": \"cam02\"", "\"name\": \"cam01\""), "rig.json"),
                    Catch::Contains("cameras[1].name") && Catch::Contains("duplicate"));
  CHECK_THROWS_WITH(parse_rig_json(with("\"units\": \"m\"", "\"units\": \"mm\""), "rig.json"),
                    Catch::Contains("units"));
  CHECK_THROWS_WITH(parse_rig_json(with("\"fps\": 100.0", "\"fps\": 0"), "rig.json"),
                    Catch::Contains("cameras[0].fps"));
  nlohmann::json j = nlohmann::json::parse(good);
  j["cameras"][0]["R_CW"][0][0] = 2.0;
  CHECK_THROWS_WITH(parse_rig_json(j.dump(), "rig.json"),
                    Catch::Contains("cameras[0].R_CW") && Catch::Contains("rotation"));
  CHECK_THROWS_WITH(look_at(Eigen::Vector3d(0, 0, 3), Eigen::Vector3d(0, 0, 1)),
                    Catch::Contains("straight up or down"));
}

}  // namespace biodyn::capture
