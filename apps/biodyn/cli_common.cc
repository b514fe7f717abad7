#include "cli_common.h"

#include <algorithm>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <system_error>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/log.h"

namespace biodyn::apps {

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) out.push_back(part);
  return out;
}

std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::string& expected) {
  std::vector<double> out;
  for (const std::string& part : split_commas(text)) {
    try {
      std::size_t used = 0;
      out.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw sim::InvalidArgument(option + ": expected " + expected + ", got '" + text + "'");
    }
  }
  return out;
}

void CharacterOptions::add_to(CLI::App* cmd, bool with_overrides) {
  cmd->add_option("--height", height_m, "Standing height, m")->capture_default_str();
  cmd->add_option("--mass", mass_kg, "Body mass, kg")->capture_default_str();
  cmd->add_option("--sex", sex, "male or female (de Leva 1996 tables)")->capture_default_str();
  cmd->add_option("--detail", detail,
                  "gait (paper's lower-body model) or full (spine, neck, head, arms)")
      ->capture_default_str();
  if (with_overrides) {
    cmd->add_option("--overrides", overrides_path,
                    "JSON {\"segments\": {\"thigh\": {\"mass_kg\": 9, \"length_m\": 0.45}}}");
  }
}

models::CharacterSpec CharacterOptions::to_spec() const {
  models::CharacterSpec spec;
  spec.height_m = height_m;
  spec.mass_kg = mass_kg;
  spec.sex = models::parse_sex(sex, "--sex");
  spec.detail = models::parse_detail(detail, "--detail");
  if (!overrides_path.empty()) {
    spec.overrides = models::parse_overrides(read_text_file(overrides_path), overrides_path);
    models::check_override_names(spec.overrides, spec.detail, overrides_path);
  }
  return spec;
}

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw sim::InvalidArgument(path + ": cannot open for reading");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw sim::InvalidArgument(path + ": read error");
  return s.str();
}

void write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path target(path);
  const fs::file_status status = fs::status(target, ec);
  if (fs::exists(status) && !fs::is_regular_file(status)) {
    // A device or pipe (/dev/stdout, a fifo): stream into it; renaming over it would replace it.
    if (fs::is_directory(status)) throw sim::Error(path + ": is a directory");
    std::ofstream out(target, std::ios::binary);
    if (!(out << text) || !out.flush()) throw sim::Error(path + ": write failed");
    return;
  }
  // Keep a symlink (even a dangling one) and write the file it points to.
  for (int hops = 0; hops < 40 && fs::is_symlink(fs::symlink_status(target, ec)); ++hops) {
    const fs::path next = fs::read_symlink(target, ec);
    if (ec) break;
    target = next.is_absolute() ? next : target.parent_path() / next;
  }
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw sim::Error(path + ": cannot create directory: " + ec.message());
  }
  const fs::path tmp = target.string() + ".tmp-biodyn";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw sim::Error(path + ": cannot open for writing");
    out << text;
    out.flush();
    if (!out) {
      out.close();
      fs::remove(tmp, ec);
      throw sim::Error(path + ": write failed");
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignore;
    fs::remove(tmp, ignore);
    throw sim::Error(path + ": cannot move the finished file into place: " + ec.message());
  }
}

void plot_with_gnuplot(const std::string& command, const std::string& script_path,
                       const std::string& png_tmp, const std::string& png) {
  const std::string cmd = "gnuplot " + script_path + " 2>&1";
  std::string output;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) throw sim::Error(command + ": cannot start gnuplot (install gnuplot-nox)");
  char buffer[256];
  while (fgets(buffer, sizeof buffer, pipe) != nullptr) output += buffer;
  const int status = pclose(pipe);
  if (status != 0 || !std::filesystem::exists(png_tmp)) {
    std::filesystem::remove(png_tmp);
    throw sim::Error(command + ": gnuplot failed on " + script_path + " (exit " +
                     std::to_string(status) + "): " + output);
  }
  std::filesystem::rename(png_tmp, png);
}

void install_console_log(bool verbose) {
  sim::set_log_sink([verbose](sim::LogLevel level, std::string_view msg) {
    if (!verbose && (level == sim::LogLevel::kDebug || level == sim::LogLevel::kInfo)) return;
    std::cerr << "biodyn: " << sim::to_string(level) << ": " << msg << "\n";
  });
}

}  // namespace biodyn::apps

#include <unistd.h>

namespace biodyn::apps {

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(2) != 0) {}

void ProgressBar::update(double fraction) {
  constexpr int kWidth = 30;
  const int percent = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100.0);
  if (percent == last_percent_ || done_) return;
  last_percent_ = percent;
  if (!tty_) return;
  const int filled = percent * kWidth / 100;
  std::cerr << "\r" << label_ << " [" << std::string(static_cast<size_t>(filled), '#')
            << std::string(static_cast<size_t>(kWidth - filled), '.') << "] " << percent << "%"
            << std::flush;
}

ProgressBar::~ProgressBar() {
  if (std::uncaught_exceptions() == 0) {
    finish();
  } else if (tty_ && last_percent_ >= 0 && !done_) {
    std::cerr << "\n";
  }
}

void ProgressBar::finish() {
  if (done_) return;
  done_ = true;
  if (tty_) {
    std::cerr << "\r" << label_ << " [" << std::string(30, '#') << "] 100%\n";
  } else {
    std::cerr << label_ << ": done\n";
  }
}

}  // namespace biodyn::apps
