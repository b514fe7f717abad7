#pragma once
/// Typed errors thrown by biodyn for bad input (style.md, habit 8). Library code never prints
/// or exits; apps catch these and own the console and the exit code.

#include <stdexcept>
#include <string>

namespace biodyn::sim {

/// Base of every biodyn error: bad input named by file/field, rule and value.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An MJCF model that MuJoCo refused to load or compile. what() names the source (file path or
/// "<string>") followed by MuJoCo's own error text.
class ModelLoadError : public Error {
 public:
  ModelLoadError(std::string source, const std::string& mujoco_message)
      : Error(source + ": " + mujoco_message), source_(std::move(source)) {}
  /// The file path, or "<string>" for models given as text.
  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

/// A value outside its allowed range or set; what() names the field, the rule and the value.
class InvalidArgument : public Error {
 public:
  using Error::Error;
};

}  // namespace biodyn::sim
