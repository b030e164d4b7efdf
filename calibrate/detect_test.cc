#include "calibrate/detect.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/test_util.h"

namespace curvecheck {
namespace {
using ::testing::HasSubstr;

using testing::MessageOf;

TEST(Detect, MrgingghamRefusesNonSquareBoards) {
  DetectOptions o;
  o.detector = "mrgingham";
  EXPECT_THAT(MessageOf([&] { DetectChessboards({}, BoardFromText("9x6", 25), o); }), HasSubstr("square NxN"));
}

}  // namespace
}  // namespace curvecheck
