// `curvecheck-demo`: the demo alone (`curvecheck-demo demo [-o DIR]`, the same code and outputs as `curvecheck
// demo`), linked with only the libraries the demo needs: no calibration, real camera, bench, sweep or presenter.
// `./bootstrap demo` builds this target, so a first run compiles about half of what `curvecheck` needs (issue 18).
#include "app/cli.h"
#include "app/commands.h"
#include "core/interrupt.h"

int main(int argc, char** argv) {
  // Before any thread starts: Ctrl-C or `kill` removes every temporary and ends with status 130 / 143.
  curvecheck::InstallInterruptHandling();
  return curvecheck::app::Main(
      argc, argv,
      {"curvecheck-demo",
       "curvecheck-demo: the curvecheck demo alone (the full command line is `curvecheck`, built by "
       "./bootstrap build)",
       curvecheck::app::AddDemoCommand});
}
