#pragma once
/// Where camera images come from, behind one interface: a recorded capture (one folder of
/// images or one video file per camera, with timestamps), live V4L2 cameras through OpenCV's
/// VideoCapture, or the synthetic cameras (synthetic.h) written as a recorded capture.
///
/// A recorded capture's layout (what `biodyn capture synth` writes):
///   DIR/capture.json           cameras (names, in rig order), fps, frames
///   DIR/<camera>/000000.png    8-bit grey images, one per frame ...
///   DIR/<camera>/timestamps.csv  frame,time_s (the camera's clock)
/// or DIR/<camera>.mp4|.avi|.mkv (any video OpenCV reads) with DIR/<camera>_timestamps.csv.

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace biodyn::capture {

/// One frame of every camera.
struct FrameSet {
  int index = 0;                ///< frame number from the start of the capture
  std::vector<cv::Mat> images;  ///< 8-bit grey, one per camera (empty Mat: the camera has none)
  std::vector<double> times_s;  ///< s, each camera's timestamp of its image
  /// Per camera: frames its clock says were lost before this one (a gap longer than 1.5
  /// frame periods); 0 for an unbroken stream.
  std::vector<int> dropped_before;

  /// Makes room for frame `frame` of `cameras` cameras (no frame lost yet).
  void start(int frame, int cameras) {
    index = frame;
    images.resize(static_cast<std::size_t>(cameras));
    times_s.resize(static_cast<std::size_t>(cameras));
    dropped_before.assign(static_cast<std::size_t>(cameras), 0);
  }
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual int camera_count() const = 0;
  virtual std::vector<std::string> camera_names() const = 0;
  /// Frames, or -1 when unknown (a live stream).
  virtual int frame_count() const = 0;
  /// The next frame of every camera into `frames`; false at the end. Throws sim::InvalidArgument
  /// naming the file and frame for an image that cannot be read or has the wrong size.
  virtual bool next(FrameSet* frames) = 0;
};

/// A recorded capture in `dir` (layout above); `cameras` picks and orders the cameras (empty:
/// capture.json's). Throws sim::InvalidArgument naming the file and field for a missing or
/// malformed capture.json, a camera without images, timestamps that do not increase or image
/// counts that differ between cameras.
std::unique_ptr<FrameSource> open_recorded(const std::string& dir,
                                           const std::vector<std::string>& cameras = {});

/// Live cameras: each `devices` entry is a V4L2 device (/dev/video0, or its index "0") or, for
/// tests and replays, a video file played in real time. Frames are taken from all cameras in
/// turn and stamped with the steady clock when grabbed; `fps` is what the cameras are set to.
/// `max_frames` (> 0) ends the stream. Throws sim::InvalidArgument naming a device that cannot
/// be opened.
std::unique_ptr<FrameSource> open_live(const std::vector<std::string>& devices, double fps,
                                       int max_frames);

/// Writes a recorded capture frame by frame (whole or not at all: into DIR.partial, renamed to
/// DIR by finish()).
class RecordedWriter {
 public:
  /// Starts `dir` (which must not exist) for `cameras` at `fps`. Throws sim::InvalidArgument
  /// naming the path if it exists, sim::Error if it cannot be made.
  RecordedWriter(std::string dir, std::vector<std::string> cameras, double fps);
  ~RecordedWriter();  ///< an unfinished capture is removed
  RecordedWriter(const RecordedWriter&) = delete;
  RecordedWriter& operator=(const RecordedWriter&) = delete;
  /// Frame `frames.index`'s images (8-bit grey) and times. Throws sim::Error if a write fails.
  void add(const FrameSet& frames);
  /// The folder being written (files beside the images, e.g. ground truth, go here too).
  const std::string& partial_dir() const { return partial_; }
  /// Writes capture.json (with `extra` JSON fields merged in) and the timestamps, then renames
  /// the folder into place.
  void finish(const std::string& extra_json = "{}");

 private:
  std::string dir_, partial_;
  std::vector<std::string> cameras_;
  double fps_;
  int frames_ = 0;
  std::vector<std::string> timestamps_;
  bool finished_ = false;
};

}  // namespace biodyn::capture
