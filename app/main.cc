#include "app/cli.h"

int main(int argc, char** argv) { return curvecheck::app::Main(argc, argv); }
