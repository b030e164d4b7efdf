#include "app/cli.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <exception>
#include <functional>
#include <iostream>
#include <string>

#include "core/decimal.h"
#include "core/error.h"

#ifndef CURVECHECK_VERSION
#define CURVECHECK_VERSION "unknown"
#endif

namespace curvecheck::app {
namespace {

// One exit code for every error (cli.h): a value CLI11 cannot convert and one our checks refuse are the same
// mistake to the user, and only where the check runs told them apart.
constexpr int kExitFailure = 1;

// Every numeric option of `app` and its subcommands reads decimal text only (core/decimal.h), through a
// transform that runs before the option's other checks and CLI11's conversion: CLI11 alone reads "0x10" as 16,
// "010" as 8 (an integer's base is taken from its prefix) and "" as 0. A refusal throws Error naming the option,
// what is wrong and an example (the option's default where it has one).
void RequireDecimalNumbers(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    const std::string type = option->get_type_name();
    const bool whole = type == "INT" || type == "UINT";
    if (!whole && type != "FLOAT") continue;
    const std::string name = option->get_name();
    const std::string fallback = whole ? "2" : "0.5";
    const std::string default_text = option->get_default_str();
    const std::string example =
        !default_text.empty() && DecimalProblem(default_text, whole).empty() ? default_text : fallback;
    option->transform(CLI::Validator(
        [name, whole, example](std::string& text) {
          const std::string problem = DecimalProblem(text, whole);
          if (!problem.empty()) {
            throw Error(name, problem,
                        fmt::format("give a {} such as {}", whole ? "whole number" : "decimal number", example));
          }
          // Canonical digits: CLI11 would read "010" as octal.
          if (whole) text = std::to_string(*ParseWholeNumber(text));
          return std::string();
        },
        "", "decimal"));
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) RequireDecimalNumbers(*sub);
}

// The subcommand a failed parse was in, as typed after the program's name ("sweep merge"; "" for the top level).
std::string FailedCommand(const CLI::App& app) {
  std::string path;
  const CLI::App* at = &app;
  for (;;) {
    const std::vector<CLI::App*> subs = at->get_subcommands();
    if (subs.empty()) return path;
    at = subs.back();
    path += (path.empty() ? "" : " ") + at->get_name();
  }
}

// A CLI11 parse error as the one line every error is: "WHERE: problem; see 'PROGRAM SUB --help'". WHERE is
// the option when CLI11's message starts with it ("--output is required"), else the subcommand.
std::string UsageLine(const std::string& program, const CLI::App& app, const CLI::ParseError& e,
                      const std::string& first_word) {
  const std::string command = FailedCommand(app);
  // CLI11 says "A subcommand is required" for a misspelt one.
  if (command.empty() && !first_word.empty() && first_word[0] != '-') {
    return fmt::format("{}: is not a subcommand; see '{} --help' for the list", first_word, program);
  }
  const std::string help = command.empty() ? program + " --help" : program + " " + command + " --help";
  std::string message = e.what();
  std::string where = command.empty() ? program : command;
  if (message.rfind("-", 0) == 0) {
    const size_t end = message.find_first_of(": ");
    where = message.substr(0, end);
    message = message.substr(std::min(message.size(), message.find_first_not_of(": ", end)));
  }
  if (message.size() > 1 && std::isupper(static_cast<unsigned char>(message[0])) &&
      !std::isupper(static_cast<unsigned char>(message[1]))) {
    message[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(message[0])));
  }
  return fmt::format("{}: {}; see '{}'", where, message, help);
}

}  // namespace

static std::string& CommandLineStorage() {
  static std::string line;
  return line;
}

const std::string& CommandLine() { return CommandLineStorage(); }

CLI::Validator InRange(double lo, double hi, const std::string& unit, const std::string& why) {
  return CLI::Validator(
      [=](std::string& text) {
        const std::optional<double> v = ParseDecimal(text);  // RequireDecimalNumbers refused anything else
        if (v && *v >= lo && *v <= hi) return std::string();
        return fmt::format("{} is outside {}..{}{}{} ({})", text, lo, hi, unit.empty() ? "" : " ", unit, why);
      },
      "", "in range");
}

int Main(int argc, char** argv, const Program& program) {
  for (int i = 0; i < argc; ++i) CommandLineStorage() += (i ? " " : "") + std::string(i ? argv[i] : program.name);
  CLI::App app{program.description, program.name};
  app.require_subcommand(1);
  app.fallthrough(false);

  std::function<int()> run;
  program.add_commands(app, run);

  // `curvecheck --version`: the version the report page records (PROJECT_VERSION of CMakeLists.txt).
  app.set_version_flag("--version", program.name + " " + CURVECHECK_VERSION, "Print the version and exit");
  RequireDecimalNumbers(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << program.name << ": error: " << UsageLine(program.name, app, e, argc > 1 ? argv[1] : "") << "\n";
    return kExitFailure;
  } catch (const Error& e) {  // a value refused while parsing (RequireDecimalNumbers)
    std::cerr << program.name << ": error: " << e.what() << "\n";
    return kExitFailure;
  }

  try {
    if (!run) throw Error(FailedCommand(app), "nothing to run", fmt::format("see '{} --help'", program.name));
    return run();
  } catch (const Error& e) {
    std::cerr << program.name << ": error: " << e.what() << "\n";
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << program.name << ": internal error: " << e.what() << "; please report it with the command line\n";
    return kExitFailure;
  }
}

}  // namespace curvecheck::app
