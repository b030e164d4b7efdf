#include "app/cli.h"
#include "core/interrupt.h"

int main(int argc, char** argv) {
  // Before any thread starts: Ctrl-C or `kill` removes every temporary and ends with status 130 / 143.
  curvecheck::InstallInterruptHandling();
  return curvecheck::app::Main(argc, argv);
}
