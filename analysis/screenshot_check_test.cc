#include "analysis/screenshot_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "detect/detect.h"
#include "pattern/pattern_json.h"

namespace curvecheck {
namespace {

TEST(ScreenshotDebug, Refine) {
  const PatternFile p = ReadPatternJson("/tmp/h19a/exact.json");
  cv::Mat g = ReadPhotoGray("/tmp/h19a/exact.png");
  cv::Mat lin;
  g.convertTo(lin, CV_64F, 1.0 / 255);
  cv::pow(lin, 2.2, lin);
  for (int k : {0, 7, 30}) {
    const Feature& f = p.features[k];
    const Feature& r = p.features[k + 1];
    const Feature& d = p.features[k + 15];
    auto c = RefineXCornerByEdgeAreas(lin, *f.display_px + Eigen::Vector2d(0.3, -0.2), *r.display_px - *f.display_px,
                                      *d.display_px - *f.display_px, 100);
    ASSERT_TRUE(c);
    std::cout << f.id << " err " << (c->px - *f.display_px).transpose() << " sigma " << c->sigma_px << " n "
              << c->samples << "\n";
  }
}

}  // namespace
}  // namespace curvecheck
