// biodyn capture bench: how fast a capture is processed, images already in memory (what a live
// system's frame grabber hands over), so the figure is the processing's, not the disk's or the
// PNG decoder's: blobs, epipolar matching and triangulation on every camera, then labelling
// with the per-frame IK skeleton.
#ifdef BIODYN_HAVE_CAPTURE
#include <chrono>
#include <iostream>

#include "biodyn/capture/frame_source.h"
#include "biodyn/capture/labelling.h"
#include "biodyn/capture/pipeline.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "cmd_capture.h"

namespace biodyn::apps {
using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

int run_capture_bench(const CaptureBenchOptions& o) {
  if (o.frames < 10 || o.frames > 100000)
    throw sim::InvalidArgument("--frames: 10 .. 100000, got " + std::to_string(o.frames));
  if (!o.summary_path.empty()) check_outputs({{"--summary", o.summary_path, false}}, {o.dir});
  std::string note;
  const models::CharacterSpec subject =
      o.label ? capture_subject(o.dir, o.subject, &note) : models::CharacterSpec{};
  const std::string rig_path = capture_rig_path(o.dir, o.rig_path);
  const capture::Rig rig = capture::read_rig(rig_path);
  std::vector<std::string> names;
  for (const capture::Camera& c : rig.cameras) names.push_back(c.name);
  auto source = capture::open_recorded(o.dir, names);
  // The frames into memory first (decoded, copied: the source reuses its buffers).
  std::vector<capture::FrameSet> frames;
  {
    ProgressBar bar("capture bench: loading up to " + std::to_string(o.frames) + " frames");
    capture::FrameSet set;
    while (static_cast<int>(frames.size()) < o.frames && source->next(&set)) {
      capture::FrameSet copy = set;
      for (cv::Mat& image : copy.images) image = image.clone();
      frames.push_back(std::move(copy));
      bar.update(static_cast<double>(frames.size()) / o.frames);
    }
  }
  if (frames.size() < 10) throw sim::InvalidArgument(o.dir + ": fewer than 10 frames to time");
  capture::set_image_threads(o.threads);
  const capture::Tracking2dParams tracking;
  capture::CapturePipeline pipeline(rig, o.blobs, o.reconstruction,
                                    o.tracking_2d ? &tracking : nullptr);
  std::vector<std::vector<capture::Point3>> points(frames.size());
  // One untimed frame: first-touch allocations and OpenCV's thread pool start.
  pipeline.process(frames.front(), &points.front());
  const auto t0 = Clock::now();
  for (std::size_t f = 0; f < frames.size(); ++f) pipeline.process(frames[f], &points[f]);
  const double reconstruct_s = seconds_since(t0);
  double label_s = 0;
  long labelled = 0, init_frame = -1;
  if (o.label) {
    const models::Character character = models::generate_character(subject);
    const sim::Model model = sim::Model::from_string(models::to_mjcf(character), "subject");
    capture::MarkerLabeller labeller(model, marker_labels(character));
    capture::LabelledFrame out;
    std::vector<Eigen::Vector3d> xyz;
    const auto t1 = Clock::now();
    for (std::size_t f = 0; f < frames.size(); ++f) {
      xyz.clear();
      for (const capture::Point3& p : points[f]) xyz.push_back(p.p_W);
      if (!labeller.initialised()) {
        if (labeller.initialise(xyz, &out)) init_frame = static_cast<long>(f);
      } else {
        labeller.track(xyz, &out);
      }
      labelled += out.labelled;
    }
    label_s = seconds_since(t1);
  }
  const double n = static_cast<double>(frames.size());
  const double fps = rig.cameras.front().fps;
  const cv::Size size = frames.front().images.front().size();
  const double total_fps = n / (reconstruct_s + label_s);
  const json summary = {{"capture", o.dir},
                        {"rig", rig_path},
                        {"cameras", rig.size()},
                        {"image_size", {size.width, size.height}},
                        {"camera_fps", fps},
                        {"frames", frames.size()},
                        {"threads", o.threads},
                        {"tracking_2d", o.tracking_2d},
                        {"reconstruction_frames_per_s", n / reconstruct_s},
                        {"labelling_frames_per_s", o.label ? n / label_s : 0.0},
                        {"labelled_from_frame", init_frame},
                        {"frames_per_s", total_fps},
                        {"real_time", total_fps >= fps}};
  std::cout << "capture bench: " << frames.size() << " frames of " << rig.size() << " cameras ("
            << size.width << " x " << size.height << " px, " << fps << " fps) in memory\n"
            << "  blobs + matching + triangulation: " << n / reconstruct_s << " frames/s\n";
  if (o.label)
    std::cout << "  labelling (per-frame IK skeleton):  " << n / label_s << " frames/s (labelled "
              << "from frame " << init_frame << ", " << static_cast<double>(labelled) / n
              << " markers per frame)\n";
  std::cout << "  all of it, one frame after another: " << total_fps
            << " frames/s: " << (total_fps >= fps ? "keeps up with" : "slower than")
            << " the cameras' " << fps << " fps\n";
  if (!o.summary_path.empty()) write_file_atomically(o.summary_path, json_text(summary, 2));
  return kExitOk;
}

}  // namespace biodyn::apps
#endif  // BIODYN_HAVE_CAPTURE
