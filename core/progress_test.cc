#include "core/progress.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

namespace curvecheck {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

TEST(Progress, PlainLinesWhenNotATerminal) {
  std::ostringstream out;
  {
    Progress p("capture", 3, out);  // a string stream is never a terminal
    EXPECT_FALSE(p.is_tty());
    p.Step("shot_0001.png");
    p.Step("shot_0002.png");
  }
  EXPECT_EQ(out.str(), "capture: 1/3 shot_0001.png\ncapture: 2/3 shot_0002.png\n");
}

TEST(Progress, RedrawnBarOnAForcedTerminal) {
  std::ostringstream out;
  {
    Progress p("capture", 4, out, true);
    p.Step("shot_0001.png");
    EXPECT_THAT(out.str(), HasSubstr("\r[=======>                      ] 1/4 shot_0001.png"));
    EXPECT_THAT(out.str(), Not(HasSubstr("\n")));  // one line, redrawn
    p.Step("shot_0002.png");
    EXPECT_THAT(out.str(), HasSubstr("2/4 shot_0002.png"));
    EXPECT_THAT(out.str(), HasSubstr(" s left"));  // estimated from the second step on
    p.Step("shot_0003.png");
    p.Step("shot_0004.png");
    EXPECT_THAT(out.str(), HasSubstr("[==============================] 4/4 shot_0004.png"));
    EXPECT_THAT(out.str(), Not(HasSubstr("\n")));
  }
  EXPECT_EQ(out.str().back(), '\n');  // finished with a newline
}

TEST(Progress, ResumedCountStartsAfterTheSkippedSteps) {
  std::ostringstream out;
  Progress p("capture", 5, out, false);
  p.Skip(3);
  p.Step("shot_0004.png");
  EXPECT_EQ(out.str(), "capture: 4/5 shot_0004.png\n");
}

}  // namespace
}  // namespace curvecheck
