#include "core/subprocess.h"

#include <gtest/gtest.h>
#include <signal.h>

#include "core/test_util.h"

namespace curvecheck {
namespace {

TEST(Subprocess, CollectsStdoutStderrAndTheExitStatus) {
  // Arguments go through unquoted: the space and the quote reach the program as they are.
  const ProcessResult r = RunProcess({"sh", "-c", "printf '%s' \"$1\"; echo oops >&2; exit 3", "sh", "a b'c"});
  EXPECT_EQ(r.status, 3);
  EXPECT_EQ(r.stdout_text, "a b'c");
  EXPECT_EQ(r.stderr_text, "oops\n");
  EXPECT_EQ(r.LastLine(), "oops");
}

TEST(Subprocess, LargeOutputOnBothPipesDoesNotDeadlock) {
  const ProcessResult r =
      RunProcess({"sh", "-c", "head -c 300000 /dev/zero; head -c 300000 /dev/zero >&2; echo last >&2"});
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.stdout_text.size(), 300000u);
  EXPECT_EQ(r.stderr_text.size(), 300005u);
}

TEST(Subprocess, MissingProgramIs127AndSignalIs128PlusN) {
  EXPECT_EQ(RunProcess({"curvecheck-no-such-program"}).status, 127);
  EXPECT_EQ(RunProcess({"sh", "-c", "kill -TERM $$"}).status, 128 + SIGTERM);
}

TEST(Subprocess, WorkingFolder) {
  EXPECT_EQ(RunProcess({"pwd"}, "/").stdout_text, "/\n");
}

TEST(Subprocess, CheckedRunNamesTheProgramAndQuotesItsLastLine) {
  EXPECT_EQ(testing::MessageOf([] { RunProcessChecked({"sh", "-c", "echo one >&2; echo two >&2; exit 2"},
                                                      "the test step", "do something"); }),
            "sh: the test step failed (exit status 2): two; do something");
  EXPECT_NO_THROW(RunProcessChecked({"true"}, "true", ""));
}

TEST(Subprocess, DestructorStopsARunningChild) {
  pid_t pid = 0;
  {
    ChildProcess child = ChildProcess::Start({"sleep", "30"});
    pid = child.pid();
    ASSERT_GT(pid, 0);
  }
  EXPECT_NE(::kill(pid, 0), 0);  // reaped: no such process
}

}  // namespace
}  // namespace curvecheck
