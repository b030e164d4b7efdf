// The display's light alone (DisplayLight): the area average over a whole pixel is the pixel's mean light on both
// paths (emitter structure resolved, or blurred away), a vanishing box is the point sample, and the point sample
// is the emitter's light on an emitter and black between them.
#include "synth/tracer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace curvecheck::synth_internal {
namespace {

Image8 TestImage(int channels) {
  Image8 image{6, 4, channels, {}};
  for (int i = 0; i < image.width * image.height * channels; ++i) {
    image.pixels.push_back(static_cast<uint8_t>(i * 37 % 256));
  }
  return image;
}

double Light(const DisplayModel& m, int code) { return m.black + (1 - m.black) * std::pow(code / 255.0, m.gamma); }

TEST(DisplayLight, WholePixelAverageIsThePixelMeanOnBothPaths) {
  for (const bool stripes : {true, false}) {
    for (const int channels : {1, 3}) {
      DisplayModel model;
      model.fill_factor = 0.7;
      model.rgb_stripes = stripes;
      model.black = 0.01;
      const Image8 image = TestImage(channels);
      const DisplayLight light(model, image);
      for (int j = 0; j + 1 < image.height; ++j) {
        for (int i = 0; i + 1 < image.width; ++i) {
          const float resolved = light.ShadeArea(i + 0.5, j + 0.5, 1, 1, 0, 0);
          const float blurred = light.ShadeArea(i + 0.5, j + 0.5, 1, 1, 1, 1);
          EXPECT_NEAR(resolved, blurred, 1e-6) << "stripes " << stripes << ", channels " << channels << " at " << i
                                               << ", " << j;
        }
      }
    }
  }
}

TEST(DisplayLight, PointSamplesSeeEmittersAndBlackBetweenThem) {
  DisplayModel model;
  model.fill_factor = 0.7;
  model.black = 0.01;
  const Image8 image = TestImage(3);
  const DisplayLight light(model, image);
  const int i = 2, j = 1;
  const size_t at = (static_cast<size_t>(j) * image.width + i) * 3;
  // Stripes R, G, B left to right; Image8 is BGR, so R is channel 2. Luma-weighted, scaled by 3.
  constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};
  for (int stripe = 0; stripe < 3; ++stripe) {
    const double expected = 3 * kLuma[stripe] * Light(model, image.pixels[at + static_cast<size_t>(2 - stripe)]);
    EXPECT_NEAR(light.ShadePoint(i + (stripe + 0.5) / 3, j + 0.5), expected, 1e-6) << stripe;
    // A box far below a display pixel is the point sample.
    EXPECT_EQ(light.ShadeArea(i + (stripe + 0.5) / 3, j + 0.5, 1e-4, 1e-4, 0, 0),
              light.ShadePoint(i + (stripe + 0.5) / 3, j + 0.5));
  }
  EXPECT_FLOAT_EQ(light.ShadePoint(i + 0.5, j + 0.02), 0.01f);  // between rows of emitters
  EXPECT_FLOAT_EQ(light.ShadePoint(i + 0.01, j + 0.5), 0.01f);  // between stripes
}

}  // namespace
}  // namespace curvecheck::synth_internal
