// EGL context on Mesa's surfaceless platform (headless_gl.h).
#include "biodyn/viewer/headless_gl.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>
#include <link.h>

#include <cstdio>
#include <string>
#include <vector>

#include "biodyn/sim/errors.h"

namespace biodyn::viewer {
namespace {

[[noreturn]] void fail(const char* call) {
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(eglGetError()));
  throw sim::Error(std::string("headless OpenGL: ") + call + " failed (EGL error " + code +
                   "); Mesa's EGL (libegl-mesa0) is needed");
}

}  // namespace

HeadlessGl::HeadlessGl() {
  // Surfaceless first (no display at all); the default display as a fallback.
  const auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  EGLDisplay display = EGL_NO_DISPLAY;
  if (get_platform_display != nullptr) {
    display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  }
  if (display == EGL_NO_DISPLAY) display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (display == EGL_NO_DISPLAY) fail("eglGetDisplay");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) fail("eglInitialize");
  const EGLint attributes[] = {
      EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_STENCIL_SIZE, 8,
      // No window: MuJoCo draws into its own framebuffer object.
      EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(display, attributes, &config, 1, &count) || count < 1) {
    eglTerminate(display);
    fail("eglChooseConfig (no RGB8, depth 24, stencil 8 OpenGL config)");
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    eglTerminate(display);
    fail("eglBindAPI");
  }
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, nullptr);
  if (context == EGL_NO_CONTEXT) {
    eglTerminate(display);
    fail("eglCreateContext");
  }
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    eglDestroyContext(display, context);
    eglTerminate(display);
    fail("eglMakeCurrent");
  }
  display_ = display;
  context_ = context;
}

HeadlessGl::~HeadlessGl() {
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(display_, context_);
  keep_gl_libraries_loaded();
  eglTerminate(display_);
}

void keep_gl_libraries_loaded() {
#if defined(__SANITIZE_ADDRESS__)
  // LeakSanitizer: Mesa keeps process-lifetime allocations in its libraries' globals (libglapi's
  // names of the GL functions looked up, the driver's one-time set-up). Unloaded at eglTerminate
  // or glfwTerminate, they are reported at exit as leaks from an "<unknown module>" that no
  // suppression can name; kept loaded, they stay reachable, and a real leak in Mesa is reported
  // with its library's name (tests/sanitizer/lsan.supp).
  std::vector<std::string> names;
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void* out) {
        const std::string name = info->dlpi_name;
        const std::string driver_suffix = "_dri.so";
        const bool driver =
            name.size() > driver_suffix.size() &&
            name.compare(name.size() - driver_suffix.size(), std::string::npos, driver_suffix) == 0;
        if (driver || name.find("/libglapi.so") != std::string::npos) {
          static_cast<std::vector<std::string>*>(out)->push_back(name);
        }
        return 0;
      },
      &names);
  // RTLD_NOLOAD | RTLD_NODELETE marks a loaded library as never to be unloaded (glibc); the
  // handle is deliberately never closed.
  for (const std::string& name : names)
    dlopen(name.c_str(), RTLD_LAZY | RTLD_NOLOAD | RTLD_NODELETE);
#endif
}

}  // namespace biodyn::viewer
