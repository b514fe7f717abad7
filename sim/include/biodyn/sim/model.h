#pragma once
/// RAII owners for MuJoCo's mjModel (fixed for a run) and mjData (the mutable scratch-pad),
/// after MuJoCo's own model/data split.

#include <mujoco/mujoco.h>

#include <memory>
#include <string>
#include <string_view>

namespace biodyn::sim {

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};

/// Owns one compiled mjModel. Movable, not copyable (use Model::copy() for a deep copy, e.g.
/// one per worker thread: welds toggle `eq_active`, a model field in 2.2.2).
class Model {
 public:
  /// Loads and compiles an MJCF file. Throws ModelLoadError naming `path` and MuJoCo's message.
  static Model from_file(const std::string& path);
  /// Compiles MJCF given as text; `name` (default "<string>") names it in errors. Relative
  /// includes/assets are not available. Throws ModelLoadError.
  static Model from_string(std::string_view xml, const std::string& name = "<string>");

  /// A deep copy (mj_copyModel).
  Model copy() const;

  mjModel* get() { return model_.get(); }
  const mjModel* get() const { return model_.get(); }
  mjModel& operator*() { return *model_; }
  const mjModel& operator*() const { return *model_; }
  mjModel* operator->() { return model_.get(); }
  const mjModel* operator->() const { return model_.get(); }

  /// Id of the named object of `type`, or throws InvalidArgument naming the type and name.
  int id(mjtObj type, std::string_view name) const;

 private:
  explicit Model(mjModel* m) : model_(m) {}
  std::unique_ptr<mjModel, ModelDeleter> model_;
};

/// Owns one mjData for a given model.
class Data {
 public:
  /// Allocates data for `model` and resets it to the model's initial state (qpos0).
  explicit Data(const mjModel& model);

  mjData* get() { return data_.get(); }
  const mjData* get() const { return data_.get(); }
  mjData& operator*() { return *data_; }
  const mjData& operator*() const { return *data_; }
  mjData* operator->() { return data_.get(); }
  const mjData* operator->() const { return data_.get(); }

 private:
  std::unique_ptr<mjData, DataDeleter> data_;
};

/// Copies the simulation *state* (time, qpos, qvel, act, ctrl, qacc_warmstart, qfrc_applied,
/// xfrc_applied, mocap poses, userdata) from `src` to `dst` without touching derived fields or
/// the stack. Both must belong to `m`. Cheap replacement for mj_copyData (which copies the whole
/// stack, ~11 MB in 2.2.2: walking-notes.md) when preparing a scratch mjData for queries.
void copy_state(const mjModel& m, const mjData& src, mjData* dst);

}  // namespace biodyn::sim
