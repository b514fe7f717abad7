#include "biodyn/sim/model.h"

#include <algorithm>
#include <cstring>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/log.h"

namespace biodyn::sim {
namespace {

constexpr int kErrorBufferSize = 1024;

std::string trim(const char* text) {
  std::string s(text);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s.empty() ? "unknown MuJoCo error" : s;
}

template <typename T>
void copy_array(T* dst, const T* src, int count) {
  if (count > 0) std::memcpy(dst, src, sizeof(T) * static_cast<size_t>(count));
}

/// Turns mj_loadXML's result into a model or a ModelLoadError naming `source`; a warning the
/// loader left in `error` goes to the log.
mjModel* checked_load(mjModel* m, const char* error, const std::string& source) {
  if (!m) throw ModelLoadError(source, trim(error));
  if (error[0]) log(LogLevel::kWarning, source + ": " + trim(error));
  return m;
}

}  // namespace

Model Model::from_file(const std::string& path) {
  install_mujoco_handlers();
  char error[kErrorBufferSize] = "";
  return Model(
      checked_load(mj_loadXML(path.c_str(), nullptr, error, kErrorBufferSize), error, path));
}

Model Model::from_string(std::string_view xml, const std::string& name) {
  install_mujoco_handlers();
  // MuJoCo 2.2.2 loads text only through its virtual file system.
  static constexpr const char* kVirtualName = "biodyn_model.xml";
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  if (mj_makeEmptyFileVFS(&vfs, kVirtualName, static_cast<int>(xml.size())) != 0) {
    mj_deleteVFS(&vfs);
    throw ModelLoadError(name, "could not allocate a virtual file for the MJCF text");
  }
  const int index = mj_findFileVFS(&vfs, kVirtualName);
  std::memcpy(vfs.filedata[index], xml.data(), xml.size());
  char error[kErrorBufferSize] = "";
  mjModel* m = mj_loadXML(kVirtualName, &vfs, error, kErrorBufferSize);
  mj_deleteVFS(&vfs);
  return Model(checked_load(m, error, name));
}

Model Model::copy() const { return Model(mj_copyModel(nullptr, model_.get())); }

int Model::id(mjtObj type, std::string_view name) const {
  const std::string key(name);
  const int i = mj_name2id(model_.get(), type, key.c_str());
  if (i < 0) {
    const char* type_name = mju_type2Str(type);
    throw InvalidArgument(std::string("model has no ") + (type_name ? type_name : "object") +
                          " named '" + key + "'");
  }
  return i;
}

Data::Data(const mjModel& model) {
  install_mujoco_handlers();
  data_.reset(mj_makeData(&model));
  if (!data_) throw Error("mj_makeData failed: out of memory");
}

void copy_state(const mjModel& m, const mjData& src, mjData* dst) {
  dst->time = src.time;
  copy_array(dst->qpos, src.qpos, m.nq);
  copy_array(dst->qvel, src.qvel, m.nv);
  copy_array(dst->act, src.act, m.na);
  copy_array(dst->ctrl, src.ctrl, m.nu);
  copy_array(dst->qacc_warmstart, src.qacc_warmstart, m.nv);
  copy_array(dst->qfrc_applied, src.qfrc_applied, m.nv);
  copy_array(dst->xfrc_applied, src.xfrc_applied, 6 * m.nbody);
  copy_array(dst->mocap_pos, src.mocap_pos, 3 * m.nmocap);
  copy_array(dst->mocap_quat, src.mocap_quat, 4 * m.nmocap);
  copy_array(dst->userdata, src.userdata, m.nuserdata);
}

}  // namespace biodyn::sim
