#include <string_view>

#include "app/cli.h"
#include "app/commands.h"
#include "core/interrupt.h"

namespace {

// The presenter (`present`, `render --present`) quits on SIGTERM and SIGINT by its own handlers, as a capture
// script's documented way to end it (exit 0, render/presenter.h); it writes no output set to protect.
bool RunsThePresenter(int argc, char** argv) {
  if (argc < 2) return false;
  const std::string_view command = argv[1];
  if (command == "present") return true;
  if (command != "render") return false;
  for (int i = 2; i < argc; ++i) {
    if (std::string_view(argv[i]) == "--present") return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread starts: Ctrl-C or `kill` removes every temporary and ends with status 130 / 143.
  if (!RunsThePresenter(argc, argv)) curvecheck::InstallInterruptHandling();
  return curvecheck::app::Main(
      argc, argv,
      {"curvecheck", "curvecheck: photogrammetric validation of curved (and flat) monitors",
       curvecheck::app::AddAllCommands});
}
