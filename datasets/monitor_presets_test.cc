#include "datasets/monitor_presets.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace curvecheck {
namespace {

TEST(MonitorPresets, AllRequiredPresetsLoadWithTheirGeometry) {
  struct Want {
    const char* name;
    int nx, ny;
    double radius_mm;  // 0 = flat
    double width_mm, height_mm;
  };
  // Widths and heights: thesis Eq 4.2 for diagonal presets, the datasheet active area otherwise.
  const Want wants[] = {
      {"49in-5120x1440-1000r", 5120, 1440, 1000, 1198.1, 336.97},
      {"49in-5120x1440-1800r", 5120, 1440, 1800, 1198.1, 336.97},
      {"34in-3440x1440-1900r", 3440, 1440, 1900, 799.8, 334.8},
      {"38in-3840x1600-2300r", 3840, 1600, 2300, 879.7, 366.5},
      {"55in-3840x2160-1000r", 3840, 2160, 1000, 1217.59, 684.89},
      {"27in-2560x1440-flat", 2560, 1440, 0, 596.74, 335.66},
  };
  for (const Want& w : wants) {
    const Monitor m = LoadMonitor(w.name);
    EXPECT_EQ(m.width_px, w.nx) << w.name;
    EXPECT_EQ(m.height_px, w.ny) << w.name;
    if (w.radius_mm == 0) {
      EXPECT_TRUE(m.is_flat()) << w.name;
    } else {
      EXPECT_NEAR(m.radius_mm(), w.radius_mm, 1e-9) << w.name;
    }
    EXPECT_NEAR(m.width_mm, w.width_mm, 0.06) << w.name;
    EXPECT_NEAR(m.height_mm, w.height_mm, 0.06) << w.name;
  }
  EXPECT_EQ(LoadMonitor("default").name, LoadMonitor(kDefaultMonitorPreset).name);
}

TEST(MonitorPresets, UnknownNameListsThePresets) {
  try {
    LoadMonitor("no-such-monitor");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("no-such-monitor: is neither a monitor preset"));
    EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("27in-2560x1440-flat"));
  }
}

}  // namespace
}  // namespace curvecheck
