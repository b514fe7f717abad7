#pragma once
/// `biodyn mocap`'s subcommands, one add_mocap_*_command each (info in cmd_mocap.cc, the others
/// in cmd_mocap_<name>.cc), which add_mocap_command (commands.h) registers, and what they share.

#include <mujoco/mujoco.h>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "commands.h"

namespace biodyn::apps {

/// Capture and motion file formats, told by the extension.
enum class Format { kC3d, kTrc, kBvh, kCsv };

/// The format of `path` from its extension (case-insensitive). Throws sim::InvalidArgument
/// naming `option` for any other extension.
Format format_of(const std::string& path, const std::string& option);

/// What a reader did to the file's contents that a user should know: names that were not UTF-8
/// (read as Latin-1) and TRC samples stored as 0 0 0 (read as gaps). Empty when nothing.
std::vector<std::string> reader_notes(int transcoded_names, int zero_samples);

/// How a command runs inverse dynamics (`mocap id`, and `mocap so` without --id): the options
/// as typed.
struct IdSettings {
  std::string grf = "none";  ///< --grf: none | plates (from-c3d) | estimate (contact)
  std::string c3d;           ///< --c3d: the capture whose force plates from-c3d applies
  std::string lab_up = "z";  ///< --lab-up: the capture lab's vertical, z or y
  double cutoff_hz = 6.0;    ///< --cutoff: Hz, the positions' low-pass (0: none)
};

/// Whether --grf `grf` asks for the kinematic estimate ("contact" is its old name: the estimate
/// replaced MuJoCo's floor contact inverted on kinematic data, which spiked to 10^4-10^5 N).
inline bool is_estimate(const std::string& grf) { return grf == "estimate" || grf == "contact"; }

/// The ground forces IdSettings ask for.
struct IdGround {
  mocap_io::GroundForces ground = mocap_io::GroundForces::kNone;
  /// the plates, turned to z up: applied (plates), or checked against (estimate)
  std::vector<mocap_io::ForcePlate> plates;
  double plate_rate_hz = 0.0;  ///< Hz, the plates' sample rate
};

/// Reads the ground forces `s` asks for (the plates of --c3d for from-c3d). Throws
/// sim::InvalidArgument naming the option and value (or mocap_io's errors for the file).
IdGround id_ground(const IdSettings& s);

/// Inverse dynamics of a motion as `mocap id` runs it.
struct MotionId {
  mocap_io::InverseDynamicsResult id;
  mocap_io::Motion motion;  ///< the frames used: the motion's longest run of solved frames
  int first_frame = 0;      ///< the file's index of motion's first frame
  int trim_frames = 0;      ///< frames at each end of `motion` that id leaves out
};

/// Runs inverse dynamics of `all` (its columns checked against `model`) on its longest run of
/// solved frames, with the filter and ground of `s` and `ground`, under a progress bar named
/// `command` (none when empty). Appends to `notes` the solved frames left out and a --c3d that is
/// not read. Throws sim::InvalidArgument for a motion inverse dynamics refuses
/// (mocap_io/inverse_dynamics.h).
MotionId run_motion_id(const mjModel& model, const mocap_io::Motion& all, const IdSettings& s,
                       const IdGround& ground, const std::string& command,
                       std::vector<std::string>* notes);

/// Marker IK of a capture (.c3d or .trc) as `mocap ik --c3d|--trc CAPTURE --lab-up UP
/// [--markerset SET] -o OUTPUT --json JSON` runs it (otherwise its defaults: the trial scales the
/// body, 80 kg): writes OUTPUT (qpos CSV with its body), its .body.json and .xml beside it and the
/// fit's JSON, and prints the fit. Throws sim::InvalidArgument naming `option` for another
/// extension, and as `mocap ik` does (no frame solved, ...).
void run_capture_ik(const std::string& capture, const std::string& option,
                    const std::string& lab_up, const std::string& markerset,
                    const std::string& output, const std::string& json_path);

/// `mocap info FILE`: what a capture file holds.
Command add_mocap_info_command(CLI::App* mocap);
/// `mocap convert IN OUT`: C3D/TRC markers to TRC or C3D, or a BVH rewritten (scaled).
Command add_mocap_convert_command(CLI::App* mocap);
/// `mocap ik`: marker IK of a capture on a generated character (cmd_mocap_ik.cc).
Command add_mocap_ik_command(CLI::App* mocap);
/// `mocap id`: inverse dynamics of a motion on a generated character (cmd_mocap_id.cc).
Command add_mocap_id_command(CLI::App* mocap);
/// `mocap retarget`: a BVH motion on a generated character (cmd_mocap_retarget.cc).
Command add_mocap_retarget_command(CLI::App* mocap);
/// `mocap so`: static optimisation, the joint torques of a motion shared among the legs' Hill
/// muscles (cmd_mocap_so.cc).
Command add_mocap_so_command(CLI::App* mocap);
/// `mocap track`: physics tracking of a motion (SAMCON; cmd_mocap_track.cc).
Command add_mocap_track_command(CLI::App* mocap);

}  // namespace biodyn::apps
