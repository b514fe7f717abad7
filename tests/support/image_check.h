#pragma once
// Reads a rendered PNG back and counts the character's pixels (render and view tests).
#include <stb/stb_image.h>

#include <string>

namespace biodyn::testing {

/// Where the character's pixels are in a frame the camera points at it.
struct CharacterPixels {
  bool loaded = false;
  int width = 0, height = 0;
  int middle = 0;  ///< in the middle third of the width
  int edges = 0;   ///< in the outer eighths
};

/// The character's colour is MuJoCo's default geom material (a warm tan), against the
/// blue-grey floor and the black sky.
inline CharacterPixels count_character_pixels(const std::string& png) {
  CharacterPixels c;
  int channels = 0;
  unsigned char* img = stbi_load(png.c_str(), &c.width, &c.height, &channels, 3);
  if (img == nullptr) return c;
  c.loaded = true;
  for (int y = 0; y < c.height; ++y) {
    for (int x = 0; x < c.width; ++x) {
      const unsigned char* p = img + 3 * (y * c.width + x);
      if (!(p[0] > 120 && p[0] > p[2] + 40 && p[1] > p[2])) continue;
      if (x > c.width / 3 && x < 2 * c.width / 3) ++c.middle;
      if (x < c.width / 8 || x > 7 * c.width / 8) ++c.edges;
    }
  }
  stbi_image_free(img);
  return c;
}

/// Pixels of `png` whose RGB `is_colour` accepts, -1 if unreadable.
template <typename Predicate>
int count_pixels(const std::string& png, Predicate is_colour) {
  int width = 0, height = 0, channels = 0;
  unsigned char* img = stbi_load(png.c_str(), &width, &height, &channels, 3);
  if (img == nullptr) return -1;
  int n = 0;
  for (int i = 0; i < width * height; ++i) {
    const unsigned char* p = img + 3 * i;
    if (is_colour(p[0], p[1], p[2])) ++n;
  }
  stbi_image_free(img);
  return n;
}

/// Pixels of the stones' green (the overlays' "stepped on within 2 cm"), -1 if unreadable.
inline int count_green_stone_pixels(const std::string& png) {
  return count_pixels(png, [](int r, int g, int b) { return g > 120 && g > r + 60 && g > b + 40; });
}

/// Pixels of an active muscle's red (viewer/overlays.h, activation_rgba: about 0.5 and above,
/// as lit and seen through the see-through body), -1 if unreadable. Nothing else in a frame
/// without pushes or glued welds in tension is this red.
inline int count_active_muscle_pixels(const std::string& png) {
  return count_pixels(png,
                      [](int r, int g, int b) { return r > 140 && g < 90 && b < 90 && r > 2 * g; });
}

}  // namespace biodyn::testing
