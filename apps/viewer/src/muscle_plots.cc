// The viewer's live muscle plots (muscle_plots.h).
#include "muscle_plots.h"

#include <imgui.h>

#include <algorithm>
#include <cstdio>

#include "biodyn/muscles/muscle_drive.h"
#include "biodyn/viewer/overlays.h"

namespace biodyn::viewer {
namespace {

/// Pixels: one muscle's activation plot and one joint's share plot.
constexpr float kActivationPlotHeight = 18, kSharePlotHeight = 24;

/// The side a name's suffix gives ("_l" left, "_r" right), or -1.
int side_of(const std::string& name) {
  if (name.size() > 2 && name.compare(name.size() - 2, 2, "_l") == 0) return models::kLeft;
  if (name.size() > 2 && name.compare(name.size() - 2, 2, "_r") == 0) return models::kRight;
  return -1;
}

/// Sample i of a ring, oldest first (ImGui::PlotLines' getter).
float series_value(void* data, int i) {
  const auto* s = static_cast<const MusclePlots::Series*>(data);
  return s->values[(s->head - s->count + i + MusclePlots::kSamples) % MusclePlots::kSamples];
}

ImVec4 to_imgui(const std::array<float, 4>& c) { return ImVec4(c[0], c[1], c[2], c[3]); }

/// The colour scale, relaxed to fully active, as a bar the width of the plots.
void activation_legend() {
  const float width = ImGui::CalcItemWidth(), height = ImGui::GetTextLineHeight();
  const ImVec2 at = ImGui::GetCursorScreenPos();
  const ImU32 relaxed = ImGui::ColorConvertFloat4ToU32(to_imgui(activation_rgba(0.0)));
  const ImU32 active = ImGui::ColorConvertFloat4ToU32(to_imgui(activation_rgba(1.0)));
  ImGui::GetWindowDrawList()->AddRectFilledMultiColor(at, ImVec2(at.x + width, at.y + height),
                                                      relaxed, active, active, relaxed);
  ImGui::Dummy(ImVec2(width, height));
  ImGui::SameLine();
  ImGui::TextUnformatted("activation 0 .. 1");
}

}  // namespace

void MusclePlots::init(const scenarios::LiveScenario& s) {
  muscles_.clear();
  joints_.clear();
  head_ = count_ = 0;
  const muscles::MuscleDrive* drive = s.muscles();
  if (drive == nullptr) return;
  for (const muscles::MuscleParams& p : drive->set().params()) {
    const int side = side_of(p.name);
    muscles_.push_back({side < 0 ? p.name : p.name.substr(0, p.name.size() - 2), side, {}});
  }
  // A ball joint's DOFs together, as the run summaries' shares (scenarios::muscle_report).
  const mjModel& m = s.simulation().model();
  const std::vector<int>& dofs = drive->set().covered_dofs();
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    const char* name = mj_id2name(&m, mjOBJ_JOINT, m.dof_jntid[dofs[k]]);
    const std::string joint = name != nullptr ? name : "dof " + std::to_string(dofs[k]);
    if (joints_.empty() || joints_.back().name != joint) {
      joints_.push_back({});
      joints_.back().name = joint;
      joints_.back().side = side_of(joint);
    }
    joints_.back().rows.push_back(static_cast<int>(k));
  }
}

void MusclePlots::sample(const scenarios::LiveScenario& s) {
  const muscles::MuscleDrive* drive = s.muscles();
  if (drive == nullptr || muscles_.empty()) return;
  const muscles::MuscleDriveState& st = drive->state();
  const std::size_t slot = static_cast<std::size_t>(head_);
  const std::size_t previous = static_cast<std::size_t>((head_ + kSamples - 1) % kSamples);
  for (std::size_t i = 0; i < muscles_.size() && i < st.activation.size(); ++i)
    muscles_[i].activation[slot] = static_cast<float>(st.activation[i]);
  for (Joint& j : joints_) {
    double muscle = 0, backup = 0;
    for (const int r : j.rows) {
      muscle += st.muscle_impulse_Nms[static_cast<std::size_t>(r)];
      backup += st.backup_impulse_Nms[static_cast<std::size_t>(r)];
    }
    // The share over the last 20 ms from the run's integrals; after a rewind or a reset they
    // went back (the window is unknown) and, with no torque in the window, the share is
    // undefined: the plot holds its last value then.
    const double dm = muscle - j.muscle_Nms, db = backup - j.backup_Nms;
    j.muscle_share[slot] = dm >= 0 && db >= 0 && dm + db > 0 ? static_cast<float>(dm / (dm + db))
                                                             : j.muscle_share[previous];
    j.muscle_Nms = muscle;
    j.backup_Nms = backup;
  }
  head_ = (head_ + 1) % kSamples;
  count_ = std::min(count_ + 1, kSamples);
}

void MusclePlots::draw(int* leg) const {
  ImGui::RadioButton("left leg", leg, models::kLeft);
  ImGui::SameLine();
  ImGui::RadioButton("right leg", leg, models::kRight);
  activation_legend();
  const std::size_t newest = static_cast<std::size_t>((head_ + kSamples - 1) % kSamples);
  char overlay[96];
  for (const Muscle& mu : muscles_) {
    if (mu.side != *leg) continue;
    const float a = mu.activation[newest];
    std::snprintf(overlay, sizeof overlay, "%.2f", a);
    // The line in the muscle's colour now: the scene's tendon has it too.
    ImGui::PushStyleColor(ImGuiCol_PlotLines, to_imgui(activation_rgba(a)));
    Series series{mu.activation.data(), head_, count_};
    ImGui::PlotLines(mu.label.c_str(), series_value, &series, count_, 0, overlay, 0.0f, 1.0f,
                     ImVec2(0, kActivationPlotHeight));
    ImGui::PopStyleColor();
  }
  ImGui::Separator();
  ImGui::TextWrapped(
      "Share of each joint's torque the muscles gave (the rest: the backups), per 20 ms:");
  for (const Joint& j : joints_) {
    if (j.side != *leg) continue;
    const float share = j.muscle_share[newest];
    const double run =
        j.muscle_Nms + j.backup_Nms > 0 ? j.muscle_Nms / (j.muscle_Nms + j.backup_Nms) : 0.0;
    ImGui::Text("%s: muscles %.0f%% now, %.0f%% over the run", j.name.c_str(), 100.0 * share,
                100.0 * run);
    ImGui::PushID(j.name.c_str());
    Series series{j.muscle_share.data(), head_, count_};
    ImGui::PlotLines("##share", series_value, &series, count_, 0, nullptr, 0.0f, 1.0f,
                     ImVec2(ImGui::GetContentRegionAvail().x, kSharePlotHeight));
    ImGui::PopID();
  }
}

}  // namespace biodyn::viewer
