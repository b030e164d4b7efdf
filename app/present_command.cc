#include "app/present_command.h"

#include "app/cli.h"

#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace curvecheck::app {

int RunPresent(const PresenterOptions& options) {
  options.Check("present");
  return RunPresenter(options, std::cout);
}

void AddPresentCommand(CLI::App& app, std::function<int()>& run) {
  // Owned by the callback, which outlives parsing (CLI::App keeps it).
  auto options = std::make_shared<PresenterOptions>();
  auto images = std::make_shared<std::vector<std::string>>();
  CLI::App* cmd = app.add_subcommand(
      "present",
      "Show PNG patterns fullscreen on one output, pixel for pixel (image size = the output's mode; never scaled). "
      "Next: Space/Right/N or SIGUSR1; previous: Left/P; quit: Escape/Q, SIGTERM or SIGINT. Prints "
      "'shown k/n path' on stdout once each image is on screen");
  cmd->add_option("--display,-d", options->display, "Output (monitor) number as GLFW lists them; 0 is the primary")
      ->capture_default_str()
      ->check(InRange(0, 255, "", "an output number: 0 is the primary"));
  cmd->add_option("--hold-ms", options->hold_ms,
                  "Keep each image this many milliseconds (1 to 86400000, one day), then show the next; exit after "
                  "the last (unattended)")
      ->check(InRange(1, 86400000, "ms", "at least 1 ms, at most one day"));
  cmd->add_flag("--windowed", options->windowed,
                "An undecorated window at the output's position and size instead of exclusive fullscreen "
                "(tests, Xvfb)");
  cmd->add_option("images", *images, "PNG files (8-bit gray, RGB or RGBA), each of the output's resolution")
      ->required();
  cmd->callback([options, images, &run] {
    options->images.assign(images->begin(), images->end());
    run = [options] { return RunPresent(*options); };
  });
}

}  // namespace curvecheck::app
