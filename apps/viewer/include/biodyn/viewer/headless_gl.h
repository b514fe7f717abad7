#pragma once
/// An OpenGL context without a display (EGL on Mesa's surfaceless platform), for `biodyn render`
/// and tests: MuJoCo renders into its own offscreen buffer, so no window or X server is needed
/// (mujoco-2.2.2.md, Rendering).
namespace biodyn::viewer {

class HeadlessGl {
 public:
  /// Creates the context and makes it current on this thread. Throws sim::Error naming the EGL
  /// call that failed and its error code.
  HeadlessGl();
  ~HeadlessGl();
  HeadlessGl(const HeadlessGl&) = delete;
  HeadlessGl& operator=(const HeadlessGl&) = delete;

 private:
  void* display_ = nullptr;
  void* context_ = nullptr;
};

/// In a build with AddressSanitizer (./test.sh --sanitize), keeps Mesa's OpenGL libraries
/// (libglapi, the *_dri.so driver) loaded until the process exits; does nothing otherwise. Called
/// before the teardown that would unload them (eglTerminate, glfwTerminate). Throws nothing.
void keep_gl_libraries_loaded();

}  // namespace biodyn::viewer
