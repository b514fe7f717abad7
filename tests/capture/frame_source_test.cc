// Camera sources (frame_source.h): a recorded capture read back as written, from image folders
// or lossless videos; timestamps checked and gaps counted as dropped frames; videos played as
// live cameras lose the frames a slow reader falls behind on, and say so.
#include "biodyn/capture/frame_source.h"

#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include "biodyn/sim/errors.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace biodyn::capture {
namespace {

// Frame f of camera c: black with one bright disc whose x encodes f and y encodes c.
cv::Mat frame_image(int f, int c) {
  cv::Mat m(120, 160, CV_8U, cv::Scalar(0));
  cv::circle(m, cv::Point(10 + 2 * f, 20 + 30 * c), 3, cv::Scalar(255), cv::FILLED);
  return m;
}

int frame_of(const cv::Mat& grey) {
  const cv::Moments m = cv::moments(grey);
  return static_cast<int>(std::lround((m.m10 / m.m00 - 10) / 2));  // the disc's centre
}

fs::path write_capture(const std::string& name, int frames) {
  const fs::path dir = fs::path(testing::binary_dir()) / "frame_source_test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir.parent_path());
  RecordedWriter writer(dir.string(), {"camA", "camB"}, 100);
  FrameSet set;
  for (int f = 0; f < frames; ++f) {
    set.start(f, 2);
    for (int c = 0; c < 2; ++c) {
      set.images[c] = frame_image(f, c);
      set.times_s[c] = f / 100.0;
    }
    writer.add(set);
  }
  writer.finish(R"({"source": "test"})");
  return dir;
}

}  // namespace

TEST_CASE("Recorded capture: written and read back whole, as image folders or lossless videos") {
  const fs::path dir = write_capture("folders", 30);
  CHECK_FALSE(fs::exists(dir.string() + ".partial"));
  auto source = open_recorded(dir.string());
  REQUIRE(source->camera_count() == 2);
  CHECK(source->frame_count() == 30);
  // The same frames as FFV1 videos (lossless) with the folder's timestamps.
  const fs::path videos = dir.parent_path() / "videos";
  fs::remove_all(videos);
  fs::create_directories(videos);
  fs::copy_file(dir / "capture.json", videos / "capture.json");
  for (const char* cam : {"camA", "camB"}) {
    cv::VideoWriter w((videos / (std::string(cam) + ".mkv")).string(),
                      cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 100, cv::Size(160, 120), false);
    REQUIRE(w.isOpened());
    for (int f = 0; f < 30; ++f) w.write(frame_image(f, cam[3] == 'A' ? 0 : 1));
    fs::copy_file(dir / cam / "timestamps.csv", videos / (std::string(cam) + "_timestamps.csv"));
  }
  auto video = open_recorded(videos.string(), {"camB", "camA"});  // picked and reordered
  FrameSet a, b;
  int frames = 0;
  while (source->next(&a)) {
    REQUIRE(video->next(&b));
    CHECK(cv::norm(a.images[0], b.images[1], cv::NORM_INF) == 0);
    CHECK(cv::norm(a.images[1], b.images[0], cv::NORM_INF) == 0);
    CHECK(a.times_s[0] == Approx(frames / 100.0));
    CHECK(a.dropped_before[0] == 0);
    ++frames;
  }
  CHECK(frames == 30);
  CHECK_FALSE(video->next(&b));
}

TEST_CASE("Recorded capture: a gap in the timestamps is dropped frames, bad files are named") {
  const fs::path dir = write_capture("gaps", 10);
  // Camera B lost frames 5 and 6: its clock jumps 30 ms.
  std::string stamps = "frame,time_s\n";
  for (int f = 0; f < 10; ++f)
    stamps += std::to_string(f) + "," + std::to_string(f < 5 ? f / 100.0 : (f + 2) / 100.0) + "\n";
  std::ofstream(dir / "camB" / "timestamps.csv") << stamps;
  auto source = open_recorded(dir.string());
  FrameSet set;
  int dropped = 0;
  while (source->next(&set)) dropped += set.dropped_before[1] + set.dropped_before[0];
  CHECK(dropped == 2);

  std::ofstream(dir / "camA" / "timestamps.csv") << "frame,time_s\n0,0\n1,0\n";
  CHECK_THROWS_WITH(open_recorded(dir.string()), Catch::Contains("camA") &&
                                                     Catch::Contains("line 3") &&
                                                     Catch::Contains("increase"));
  fs::remove(dir / "camB" / "000004.png");
  std::ofstream(dir / "camA" / "timestamps.csv") << stamps;
  auto broken = open_recorded(dir.string());
  CHECK_THROWS_WITH(([&] {
                      while (broken->next(&set)) {
                      }
                    }()),
                    Catch::Contains("000004.png"));
  CHECK_THROWS_WITH(open_recorded(dir.string(), {"camC"}), Catch::Contains("camC"));
  CHECK_THROWS_WITH(open_recorded((dir / "nowhere").string()), Catch::Contains("capture.json"));
}

TEST_CASE("Live cameras: a video played as a camera loses what a slow reader falls behind on") {
  const fs::path dir = fs::path(testing::binary_dir()) / "frame_source_test" / "live";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "cam.mkv").string();
  {
    cv::VideoWriter w(path, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 100, cv::Size(160, 120),
                      false);
    REQUIRE(w.isOpened());
    for (int f = 0; f < 60; ++f) w.write(frame_image(f, 0));
  }
  auto live = open_live({path}, 100, 0);
  // A camera streams from its first read: the reader's time getting ready (here 0.2 s, 20
  // frames) costs no frame, so a capture opening with a T-pose is seen from its first frame.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  FrameSet set;
  REQUIRE(live->next(&set));
  CHECK(frame_of(set.images[0]) == 0);
  CHECK(set.dropped_before[0] == 0);
  int read = 1, dropped = 0, last = 0;
  bool in_order = true;
  while (live->next(&set)) {
    const int shown = frame_of(set.images[0]);
    in_order = in_order && shown > last && shown == last + 1 + set.dropped_before[0];
    last = shown;
    dropped += set.dropped_before[0];
    ++read;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));  // a reader at 40 frames/s
  }
  INFO("read " << read << ", dropped " << dropped);
  CHECK(in_order);  // what was lost is what the counts say
  CHECK(dropped > 20);
  // Every frame up to the last one read was read or counted as lost (frames skipped after it
  // belong to no frame set), and the stream was played to its end.
  CHECK(read + dropped == last + 1);
  CHECK(last >= 45);
  CHECK_THROWS_WITH(open_live({(dir / "none.mkv").string()}, 100, 0), Catch::Contains("none.mkv"));
}

}  // namespace biodyn::capture
