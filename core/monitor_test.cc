#include "core/monitor.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/config.h"
#include "core/error.h"

namespace curvecheck {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// Thesis 1 (introduction) and Eq 4.2: a 49" 32:9 monitor is 336.97 mm x 1198.1 mm.
TEST(Monitor, FortyNineInchSuperUltrawideMatchesThesis) {
  const Monitor m = MonitorFromDiagonal("49", 5120, 1440, 49.0, 1000.0);
  EXPECT_NEAR(m.height_mm, 336.97, 0.005);
  EXPECT_NEAR(m.width_mm, 1198.1, 0.05);
  EXPECT_NEAR(m.radius_mm(), 1000.0, 1e-12);
  EXPECT_NEAR(m.half_sector_rad(), m.width_mm / 2000.0, 1e-15);  // Eq 4.3
  EXPECT_NEAR(m.pixel_pitch_mm(), m.width_mm / 5120, 1e-15);
  EXPECT_NEAR(m.pixel_pitch_mm(), m.height_mm / 1440, 1e-12);  // square pixels from the aspect
}

TEST(Monitor, ChordAndSagittaMatchDirectFormulas) {
  const Monitor m = MonitorFromDiagonal("49", 5120, 1440, 49.0, 1000.0);
  const double theta = m.half_sector_rad();
  EXPECT_NEAR(m.chord_width_mm(), 2 * 1000 * std::sin(theta), 1e-9);  // Eq 4.4 w_n
  EXPECT_NEAR(m.sagitta_mm(), 1000 * (1 - std::cos(theta)), 1e-9);
  const Monitor flat = MonitorFromDiagonal("flat", 5120, 1440, 49.0, 0);
  EXPECT_TRUE(flat.is_flat());
  EXPECT_TRUE(std::isinf(flat.radius_mm()));
  EXPECT_EQ(flat.chord_width_mm(), flat.width_mm);
  EXPECT_EQ(flat.sagitta_mm(), 0);
}

TEST(Monitor, ConfigWithDiagonal) {
  const Monitor m = MonitorFromConfig(
      ConfigMap::Parse("format: curvecheck.monitor/1\nname: test\nresolution: [5120, 1440]\n"
                       "diagonal_in: 49\nradius_mm: 1800\n",
                       "m.yaml"));
  EXPECT_EQ(m.name, "test");
  EXPECT_EQ(m.width_px, 5120);
  EXPECT_NEAR(m.radius_mm(), 1800, 1e-12);
  EXPECT_NEAR(m.height_mm, 336.97, 0.005);
}

TEST(Monitor, ConfigWithActiveAreaAndFlatAsJson) {
  const Monitor m = MonitorFromConfig(ConfigMap::Parse(
      R"({"resolution": [2560, 1440], "active_area_mm": [596.74, 335.66], "radius_mm": "flat"})", "m.json"));
  EXPECT_TRUE(m.is_flat());
  EXPECT_DOUBLE_EQ(m.width_mm, 596.74);
  EXPECT_EQ(m.name, "m.json");  // no name: the source names it
}

// Each bad spec must fail with the file, the key and the problem; never a silent default.
struct BadSpec {
  const char* yaml;
  const char* expected_substring;
};

class MonitorBadConfig : public ::testing::TestWithParam<BadSpec> {};

TEST_P(MonitorBadConfig, FailsWithClearMessage) {
  try {
    MonitorFromConfig(ConfigMap::Parse(GetParam().yaml, "bad.yaml"));
    FAIL() << "accepted: " << GetParam().yaml;
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), AllOf(HasSubstr("bad.yaml"), HasSubstr(GetParam().expected_substring)));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, MonitorBadConfig,
    ::testing::Values(
        BadSpec{"diagonal_in: 49\nradius_mm: 1000\n", "key 'resolution' is missing"},
        BadSpec{"resolution: [5120, 1440]\nradius_mm: 1000\n", "key 'diagonal_in' is missing"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\n", "key 'radius_mm' is missing"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: -49\nradius_mm: 1000\n", "must be greater than zero"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 0\nradius_mm: 1000\n", "must be greater than zero"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: -1000\n", "must be greater than zero"},
        BadSpec{"resolution: [5120, 0]\ndiagonal_in: 49\nradius_mm: 1000\n", "whole number of at least 1"},
        BadSpec{"resolution: [5120.5, 1440]\ndiagonal_in: 49\nradius_mm: 1000\n", "whole number"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: .nan\nradius_mm: 1000\n", "not a finite number"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: .inf\n", "not a finite number"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: forty\nradius_mm: 1000\n", "must be a number"},
        BadSpec{"resolution: 5120\ndiagonal_in: 49\nradius_mm: 1000\n", "must be a list of 2 numbers"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: round\n", "must be a number"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: 100\n", "wrap more than 360 deg"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: 1e9\n", "write radius_mm: flat"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nactive_area_mm: [1, 1]\nradius_mm: 1000\n",
                "given together with diagonal_in"},
        BadSpec{"resolution: [5120, 1440]\nactive_area_mm: [1000, 1000]\nradius_mm: 1000\n",
                "pixels are not square"},
        BadSpec{"resolution: [5120, 1440]\nactive_area_mm: [-1000, 300]\nradius_mm: 1000\n",
                "sizes must be greater than zero"},
        BadSpec{"resolution: [5120, 1440]\ndiagonal_in: 49\nradius: 1000\n", "key 'radius' is not a known key"},
        BadSpec{"format: curvecheck.monitor/9\nresolution: [5120, 1440]\ndiagonal_in: 49\nradius_mm: 1000\n",
                "not 'curvecheck.monitor/1'"}));

TEST(Monitor, MalformedYamlNamesLine) {
  try {
    ConfigMap::Parse("resolution: [5120, 1440\ndiagonal_in: 49\n", "broken.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), AllOf(HasSubstr("broken.yaml"), HasSubstr("not valid YAML at line")));
  }
}

}  // namespace
}  // namespace curvecheck
