#pragma once
// The viewer's live muscle plots (`biodyn view --muscles on`): each muscle's activation over the
// last 5 s, and per joint the muscles span the share of its torque the muscles gave (the rest
// the backups gave, muscles/muscle_drive.h), for one leg at a time. Sampled on the physics
// thread, drawn on the render thread, both under the viewer's lock.
#include <array>
#include <string>
#include <vector>

#include "biodyn/scenarios/live.h"

namespace biodyn::viewer {

class MusclePlots {
 public:
  /// Samples kept: 5 s at one every 20 ms (the viewer samples its plots every 10 steps of 2 ms).
  static constexpr int kSamples = 250;
  static constexpr double kSpan_s = 5.0;

  /// Sizes the rings for `s`'s muscles and the joints they span (nothing without muscles).
  void init(const scenarios::LiveScenario& s);
  bool empty() const { return muscles_.empty(); }
  /// Takes one sample of `s` now. No allocation.
  void sample(const scenarios::LiveScenario& s);
  /// The plots of leg `*leg` (models::kLeft or kRight; radio buttons change it): ImGui widgets
  /// in the current window.
  void draw(int* leg) const;

  /// One ring's samples oldest to newest (ImGui's plot getter).
  struct Series {
    const float* values;
    int head, count;
  };

 private:
  struct Muscle {
    std::string label;  // the name without its side, e.g. "soleus"
    int side = 0;
    std::array<float, kSamples> activation{};
  };
  struct Joint {
    std::string name;  // e.g. "hip_l"
    int side = 0;
    std::vector<int> rows;                       // its DOFs among the drive's covered DOFs
    double muscle_Nms = 0, backup_Nms = 0;       // the run's integrals at the last sample
    std::array<float, kSamples> muscle_share{};  // per sample: over the 20 ms before it
  };

  std::vector<Muscle> muscles_;
  std::vector<Joint> joints_;
  int head_ = 0;   // the next sample's slot (the oldest one once the ring is full)
  int count_ = 0;  // samples taken, up to kSamples: the plots show only those
};

}  // namespace biodyn::viewer
