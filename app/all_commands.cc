// The full `curvecheck` command line: every subcommand (app/main.cc). The demo-only program registers just
// `demo` (app/demo_main.cc).
#include <functional>

#include "app/analyze_command.h"
#include "app/bench_command.h"
#include "app/calibrate_command.h"
#include "app/capture_command.h"
#include "app/capture_synth_command.h"
#include "app/commands.h"
#include "app/export_mpcdi_command.h"
#include "app/plan_command.h"
#include "app/present_command.h"
#include "app/render_command.h"
#include "app/report_command.h"
#include "app/sweep_command.h"
#include "app/thirdparty_commands.h"

namespace curvecheck::app {

void AddAllCommands(CLI::App& app, std::function<int()>& run) {
  // `info`: app/info_command.cc.
  AddInfoCommand(app, run);
  AddDemoCommand(app, run);
  AddRenderCommand(app, run);
  // `analyze` (issue 6): app/analyze_command.cc.
  AddAnalyzeCommand(app, run);
  // `report` (issue 7 item 1): the HTML page of a result.json; app/report_command.cc.
  AddReportCommand(app, run);
  // `plan` (issue 20 part 1): the capture plan; app/plan_command.cc.
  AddPlanCommand(app, run);
  AddBenchCommand(app, run);
  // `present` (issue 3 item 8): the fullscreen presenter; app/present_command.cc.
  AddPresentCommand(app, run);
  // `capture` (issue 4 item 3): webcam, DSLR, sessions, import; app/capture_command.cc.
  CLI::App* capture = AddCaptureCommand(app, run);
  AddCaptureSynthCommand(*capture, run);
  // `calibrate` (issue 5): app/calibrate_command.cc.
  AddCalibrateCommand(app, run);

  // `sweep` (issue 7 items 3-4): app/sweep_command.cc.
  AddSweepCommand(app, run);
  // `export-mpcdi` (issue 19 part 3): app/export_mpcdi_command.cc.
  AddExportMpcdiCommand(app, run);
  // `pattern` and `check-screenshot` (issue 19): app/pattern_command.cc, app/check_screenshot_command.cc.
  AddPatternCommand(app, run);
  AddCheckScreenshotCommand(app, run);
}

}  // namespace curvecheck::app
