#include "core/config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/test_util.h"

namespace curvecheck {
namespace {

using ::testing::HasSubstr;

using testing::MessageOf;

TEST(Config, NestedKeysAreNamedWithTheirPath) {
  const ConfigMap c = ConfigMap::Parse("camera:\n  pose:\n    distance_mm: -3\n", "scene.yaml");
  EXPECT_THAT(MessageOf([&] { c.Map("camera").Map("pose").PositiveNumber("distance_mm"); }),
              HasSubstr("scene.yaml: key 'camera.pose.distance_mm' is -3, but must be greater than zero"));
  EXPECT_THAT(MessageOf([&] { c.Map("camera").String("lens"); }), HasSubstr("key 'camera.lens' is missing"));
  EXPECT_THAT(MessageOf([&] { c.String("camera"); }), HasSubstr("must be a text, got a mapping"));
}

TEST(Config, TopLevelMustBeAMapping) {
  EXPECT_THAT(MessageOf([] { ConfigMap::Parse("- 1\n- 2\n", "list.yaml"); }),
              HasSubstr("list.yaml: expected a mapping of keys at the top level, found a list"));
  EXPECT_THAT(MessageOf([] { ConfigMap::Parse("", "empty.yaml"); }), HasSubstr("found nothing"));
}

TEST(Config, NumbersAreStrict) {
  const ConfigMap c = ConfigMap::Parse("a: 1e3\nb: 12abc\nc: -.inf\nd: [1, 2, .nan]\ne: 0x10\n", "n.yaml");
  EXPECT_EQ(c.Number("a"), 1000);
  EXPECT_THAT(MessageOf([&] { c.Number("b"); }), HasSubstr("must be a number, got '12abc'"));
  EXPECT_THAT(MessageOf([&] { c.Number("c"); }), HasSubstr("not a finite number"));
  EXPECT_THAT(MessageOf([&] { c.Numbers("d", 3); }), HasSubstr("key 'd[2]' is '.nan', not a finite number"));
  EXPECT_THAT(MessageOf([&] { c.Numbers("d", 2); }), HasSubstr("must be a list of 2 numbers"));
  // Decimal only (core/decimal.h): strtod, which this used to call, reads 0x10 as 16.
  EXPECT_THAT(MessageOf([&] { c.Number("e"); }), HasSubstr("key 'e' must be a decimal number, got '0x10'"));
}

TEST(Config, NumberListOption) {
  EXPECT_EQ(ParseNumberList(" 1, -2.5 ,3e2", 3, "--viewpoint"), (std::vector<double>{1, -2.5, 300}));
  EXPECT_THAT(MessageOf([] { ParseNumberList("1,2", 3, "--viewpoint"); }),
              HasSubstr("--viewpoint: expected 3 numbers, got 2"));
  EXPECT_THAT(MessageOf([] { ParseNumberList("1,x,2", 3, "--viewpoint"); }), HasSubstr("'x' is not a number"));
  EXPECT_THAT(MessageOf([] { ParseNumberList("1,nan,2", 3, "--viewpoint"); }), HasSubstr("'nan' is not finite"));
  EXPECT_THAT(MessageOf([] { ParseNumberList("0,0,0x10", 3, "--viewpoint"); }),
              HasSubstr("--viewpoint: '0x10' is not a decimal number in '0,0,0x10'"));
  EXPECT_THAT(MessageOf([] { ParseNumberList("0,,500", 3, "--viewpoint"); }),
              HasSubstr("'' is not a number in '0,,500'"));
}

}  // namespace
}  // namespace curvecheck
