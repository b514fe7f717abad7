// Camera model, rig files (camera.h).
#include "biodyn/capture/camera.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"

namespace biodyn::capture {
namespace {

// A rotation read from a file is orthonormal to this (a rig written with %.17g keeps 1e-15).
constexpr double kOrthonormalTolerance = 1e-6;
// px: undistort() stops when the point it found maps back this close to the pixel.
constexpr double kUndistortTolerance_px = 1e-9;
constexpr int kUndistortIterations = 50;

std::string number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

[[noreturn]] void fail(const std::string& source, const std::string& field,
                       const std::string& why) {
  throw sim::InvalidArgument(source + ": " + field + ": " + why);
}

}  // namespace

void Intrinsics::validate(const std::string& where) const {
  if (width_px < 2 || height_px < 2) {
    fail(where, "width_px/height_px",
         "must be at least 2, got " + std::to_string(width_px) + " x " + std::to_string(height_px));
  }
  if (!(fx_px > 0) || !(fy_px > 0) || !std::isfinite(fx_px) || !std::isfinite(fy_px)) {
    fail(where, "fx_px/fy_px",
         "must be positive and finite, got " + number(fx_px) + ", " + number(fy_px));
  }
  for (double c : {cx_px, cy_px, k1, k2, p1, p2, k3}) {
    if (!std::isfinite(c))
      fail(where, "cx_px/cy_px/distortion", "must be finite, got " + number(c));
  }
}

void Intrinsics::to_array(double* k) const {
  const double v[kLensParams] = {fx_px, fy_px, cx_px, cy_px, k1, k2, p1, p2, k3};
  std::copy(v, v + kLensParams, k);
}

void Intrinsics::from_array(const double* k) {
  fx_px = k[0];
  fy_px = k[1];
  cx_px = k[2];
  cy_px = k[3];
  k1 = k[4];
  k2 = k[5];
  p1 = k[6];
  p2 = k[7];
  k3 = k[8];
}

Eigen::Vector2d Camera::project(const Eigen::Vector3d& p_W, bool* in_front) const {
  const Eigen::Vector3d p_C = to_camera(p_W);
  if (in_front != nullptr) *in_front = p_C.z() > 0;
  double k[kLensParams];
  K.to_array(k);
  Eigen::Vector2d uv;
  distort_to_pixels(k, p_C.x() / p_C.z(), p_C.y() / p_C.z(), &uv.x(), &uv.y());
  return uv;
}

Eigen::Vector2d Camera::project_pinhole(const Eigen::Vector3d& p_W) const {
  const Eigen::Vector3d p_C = to_camera(p_W);
  return {K.fx_px * p_C.x() / p_C.z() + K.cx_px, K.fy_px * p_C.y() / p_C.z() + K.cy_px};
}

Eigen::Vector2d Camera::undistort(const Eigen::Vector2d& uv_px) const {
  // Newton's method on distort(x) = uv, from the undistorted guess; the 2 x 2 Jacobian by
  // central differences (the model is smooth and cheap).
  Eigen::Vector2d x((uv_px.x() - K.cx_px) / K.fx_px, (uv_px.y() - K.cy_px) / K.fy_px);
  double k[kLensParams];
  K.to_array(k);
  auto distort = [&](const Eigen::Vector2d& p) {
    Eigen::Vector2d out;
    distort_to_pixels(k, p.x(), p.y(), &out.x(), &out.y());
    return out;
  };
  constexpr double h = 1e-7;
  for (int it = 0; it < kUndistortIterations; ++it) {
    const Eigen::Vector2d r = distort(x) - uv_px;
    if (r.norm() < kUndistortTolerance_px) break;
    Eigen::Matrix2d J;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector2d e = Eigen::Vector2d::Zero();
      e[axis] = h;
      J.col(axis) = (distort(x + e) - distort(x - e)) / (2 * h);
    }
    x -= J.partialPivLu().solve(r);
  }
  return x;
}

Eigen::Vector3d Camera::ray_W(const Eigen::Vector2d& uv_px) const {
  const Eigen::Vector2d x = undistort(uv_px);
  return (R_CW.transpose() * Eigen::Vector3d(x.x(), x.y(), 1.0)).normalized();
}

Eigen::Matrix<double, 3, 4> Camera::projection_matrix() const {
  Eigen::Matrix3d k;
  k << K.fx_px, 0, K.cx_px, 0, K.fy_px, K.cy_px, 0, 0, 1;
  Eigen::Matrix<double, 3, 4> Rt;
  Rt.leftCols<3>() = R_CW;
  Rt.col(3) = -R_CW * p_WC;
  return k * Rt;
}

bool Camera::in_image(const Eigen::Vector2d& uv_px) const {
  return uv_px.x() >= -0.5 && uv_px.y() >= -0.5 && uv_px.x() <= K.width_px - 0.5 &&
         uv_px.y() <= K.height_px - 0.5;
}

int Rig::find(const std::string& name) const {
  for (int i = 0; i < size(); ++i) {
    if (cameras[i].name == name) return i;
  }
  return -1;
}

std::string format_rig_json(const Rig& rig) {
  nlohmann::json cams = nlohmann::json::array();
  for (int i = 0; i < rig.size(); ++i) {
    const Camera& c = rig.cameras[i];
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) R.push_back({c.R_CW(r, 0), c.R_CW(r, 1), c.R_CW(r, 2)});
    nlohmann::json j = {{"name", c.name},
                        {"width_px", c.K.width_px},
                        {"height_px", c.K.height_px},
                        {"fx_px", c.K.fx_px},
                        {"fy_px", c.K.fy_px},
                        {"cx_px", c.K.cx_px},
                        {"cy_px", c.K.cy_px},
                        {"distortion_k1_k2_p1_p2_k3", {c.K.k1, c.K.k2, c.K.p1, c.K.p2, c.K.k3}},
                        {"R_CW", R},
                        {"p_WC_m", {c.p_WC.x(), c.p_WC.y(), c.p_WC.z()}},
                        {"fps", c.fps}};
    if (i < static_cast<int>(rig.reprojection_rms_px.size()))
      j["reprojection_rms_px"] = rig.reprojection_rms_px[i];
    cams.push_back(j);
  }
  const nlohmann::json doc = {
      {"units", "m"},
      {"frames", "world: lab, z up; camera: x right, y down, z along the optical axis (OpenCV)"},
      {"source", rig.source},
      {"cameras", cams}};
  return doc.dump(2) + "\n";
}

namespace {

double number_field(const nlohmann::json& j, const std::string& key, const std::string& source,
                    const std::string& where) {
  if (!j.contains(key)) fail(source, where + "." + key, "missing");
  if (!j[key].is_number())
    fail(source, where + "." + key, "must be a number, got " + j[key].dump());
  return j[key].get<double>();
}

Camera parse_camera(const nlohmann::json& j, const std::string& source, const std::string& where) {
  if (!j.is_object()) fail(source, where, "must be an object, got " + j.dump());
  Camera c;
  if (!j.contains("name") || !j["name"].is_string() || j["name"].get<std::string>().empty())
    fail(source, where + ".name", "must be a non-empty string");
  c.name = j["name"].get<std::string>();
  const double w = number_field(j, "width_px", source, where);
  const double h = number_field(j, "height_px", source, where);
  if (w != std::floor(w) || h != std::floor(h) || w < 2 || h < 2 || w > 1e5 || h > 1e5)
    fail(source, where + ".width_px/height_px",
         "must be whole numbers 2..100000, got " + number(w) + " x " + number(h));
  c.K.width_px = static_cast<int>(w);
  c.K.height_px = static_cast<int>(h);
  c.K.fx_px = number_field(j, "fx_px", source, where);
  c.K.fy_px = number_field(j, "fy_px", source, where);
  c.K.cx_px = number_field(j, "cx_px", source, where);
  c.K.cy_px = number_field(j, "cy_px", source, where);
  if (j.contains("distortion_k1_k2_p1_p2_k3")) {
    const nlohmann::json& d = j["distortion_k1_k2_p1_p2_k3"];
    if (!d.is_array() || d.size() != 5 ||
        !std::all_of(d.begin(), d.end(), [](auto& x) { return x.is_number(); }))
      fail(source, where + ".distortion_k1_k2_p1_p2_k3", "must be 5 numbers, got " + d.dump());
    c.K.k1 = d[0];
    c.K.k2 = d[1];
    c.K.p1 = d[2];
    c.K.p2 = d[3];
    c.K.k3 = d[4];
  }
  c.K.validate(source + ": " + where);
  const nlohmann::json R = j.value("R_CW", nlohmann::json());
  bool ok = R.is_array() && R.size() == 3;
  for (int r = 0; ok && r < 3; ++r) {
    ok = R[r].is_array() && R[r].size() == 3;
    for (int k = 0; ok && k < 3; ++k) {
      ok = R[r][k].is_number();
      if (ok) c.R_CW(r, k) = R[r][k].get<double>();
    }
  }
  if (!ok) fail(source, where + ".R_CW", "must be 3 rows of 3 numbers, got " + R.dump());
  const double off = (c.R_CW * c.R_CW.transpose() - Eigen::Matrix3d::Identity()).norm();
  if (off > kOrthonormalTolerance || c.R_CW.determinant() < 0)
    fail(source, where + ".R_CW",
         "must be a rotation (orthonormal, determinant +1): |R R^T - I| = " + number(off));
  const nlohmann::json p = j.value("p_WC_m", nlohmann::json());
  if (!p.is_array() || p.size() != 3 ||
      !std::all_of(p.begin(), p.end(), [](auto& x) { return x.is_number(); }))
    fail(source, where + ".p_WC_m", "must be 3 numbers (m), got " + p.dump());
  c.p_WC = Eigen::Vector3d(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  c.fps = j.contains("fps") ? number_field(j, "fps", source, where) : c.fps;
  if (!(c.fps > 0) || !std::isfinite(c.fps))
    fail(source, where + ".fps", "must be positive, got " + number(c.fps));
  return c;
}

}  // namespace

Rig parse_rig_json(const std::string& text, const std::string& source) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for 1e400
    fail(source, "JSON", std::string("malformed: ") + e.what());
  }
  if (!doc.is_object()) fail(source, "top level", "must be an object");
  if (doc.contains("units") && doc["units"] != "m")
    fail(source, "units", "must be \"m\" (metres), got " + doc["units"].dump());
  if (!doc.contains("cameras") || !doc["cameras"].is_array() || doc["cameras"].empty())
    fail(source, "cameras", "must be a non-empty array");
  Rig rig;
  rig.source = doc.value("source", std::string());
  std::set<std::string> names;
  for (std::size_t i = 0; i < doc["cameras"].size(); ++i) {
    const std::string where = "cameras[" + std::to_string(i) + "]";
    const nlohmann::json& j = doc["cameras"][i];
    rig.cameras.push_back(parse_camera(j, source, where));
    if (!names.insert(rig.cameras.back().name).second)
      fail(source, where + ".name", "duplicate camera name \"" + rig.cameras.back().name + "\"");
    if (j.contains("reprojection_rms_px") && j["reprojection_rms_px"].is_number())
      rig.reprojection_rms_px.push_back(j["reprojection_rms_px"].get<double>());
  }
  if (rig.reprojection_rms_px.size() != rig.cameras.size()) rig.reprojection_rms_px.clear();
  return rig;
}

Rig read_rig(const std::string& path) { return parse_rig_json(sim::read_file(path), path); }

void write_rig(const std::string& path, const Rig& rig) {
  sim::write_file_atomically(path, format_rig_json(rig), sim::MissingDirectories::kCreate);
}

Eigen::Matrix3d look_at(const Eigen::Vector3d& p_WC, const Eigen::Vector3d& target_W) {
  const Eigen::Vector3d z = target_W - p_WC;
  if (z.norm() < 1e-9) throw sim::InvalidArgument("look_at: the target is the camera's centre");
  const Eigen::Vector3d zc = z.normalized();
  const Eigen::Vector3d x = zc.cross(Eigen::Vector3d::UnitZ());  // image right
  if (x.norm() < 1e-6)
    throw sim::InvalidArgument("look_at: a camera looking straight up or down has no image up");
  const Eigen::Vector3d xc = x.normalized();
  const Eigen::Vector3d yc = zc.cross(xc);  // image down
  Eigen::Matrix3d R;
  R.row(0) = xc.transpose();
  R.row(1) = yc.transpose();
  R.row(2) = zc.transpose();
  return R;
}

}  // namespace biodyn::capture
