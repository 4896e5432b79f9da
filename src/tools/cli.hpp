// Command-line conventions shared by the programs in src/tools (CLI11, header-only):
//  - `-h` / `--help` prints the usage (every option with a one-line description) on stdout and
//    exits 0;
//  - an unknown option, a missing argument or a bad value prints "<tool>: <what>" on stderr,
//    naming the option, and exits 2;
//  - an option given twice keeps its last value (as the hand-written loops these replace did),
//    except the repeatable ones (vectors), which collect every value.
#pragma once

#include <CLI/CLI.hpp>

#include <cctype>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

namespace drill_pipe_pose::tools {

/// Exit status of a command-line error (unknown option, bad or missing value).
constexpr int kUsageExit = 2;

/// Gives an App the tools' conventions. Note: with TakeLast, CLI11 does not reject too few values
/// for an option of several (expected(N)); such options check their count after parsing.
inline void configureApp(CLI::App& app) {
  app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app.get_formatter()->column_width(34);
}

/// Prints "<tool>: <what>" and a hint, and exits with kUsageExit.
[[noreturn]] inline void usageError(const CLI::App& app, const std::string& what) {
  std::cerr << app.get_name() << ": " << what << "\nRun '" << app.get_name()
            << " --help' for the usage.\n";
  std::exit(kUsageExit);
}

/// Parses the command line: on --help prints the usage and exits 0; on any parse or validation
/// error calls usageError (exit 2).
inline void parseOrExit(CLI::App& app, int argc, char** argv) {
  // An unknown option is named first: CLI11 would otherwise report a missing required argument
  // before it (e.g. "BAG is required" for `bench_estimator --bogus`).
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--") break;
    const bool looks_like_option = a.size() > 1 && a[0] == '-' &&
                                   !(std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.');
    if (looks_like_option && !app.get_option_no_throw(a.substr(0, a.find('='))))
      usageError(app, "unknown option " + a.substr(0, a.find('=')));
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) std::exit(app.exit(e));
    usageError(app, e.what());
  }
}

/// A validator from a function that throws (std::exception) on a bad value, such as the core's
/// own parsers, so that the option's accepted values have one source. `description` is what the
/// usage shows after the type (e.g. "ours|thesis_baseline").
template <class F>
CLI::Validator throwingCheck(const std::string& description, F check) {
  return CLI::Validator(
      [check](std::string& value) -> std::string {
        try {
          check(value);
        } catch (const std::exception& e) {
          return e.what();
        }
        return std::string();
      },
      description);
}

/// A repeatable `name KEY=VALUE` option: each pair is checked by `check(name, key, value)` (which
/// throws CLI::ValidationError for a bad one, so that it exits 2 naming the option) and appended
/// to `out` in the order given.
template <class Check>
CLI::Option* addKeyValueOption(CLI::App& app, const std::string& name,
                               std::vector<std::pair<std::string, std::string>>* out, Check check,
                               const std::string& description) {
  return app
      .add_option_function<std::vector<std::string>>(
          name,
          [name, out, check](const std::vector<std::string>& kvs) {
            for (const std::string& kv : kvs) {
              const size_t eq = kv.find('=');
              if (eq == std::string::npos || eq == 0)
                throw CLI::ValidationError(name, "expected KEY=VALUE, got '" + kv + "'");
              check(name, kv.substr(0, eq), kv.substr(eq + 1));
              out->emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
            }
          },
          description)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->option_text("KEY=VALUE");
}

/// Why an axis-aligned box given as x0 y0 z0 x1 y1 z1 is not one (6 numbers, min < max on every
/// axis); empty when it is.
inline std::string boxError(const std::vector<double>& v) {
  if (v.size() != 6) return "expected 6 numbers: x0 y0 z0 x1 y1 z1";
  for (int k = 0; k < 3; ++k)
    if (!(v[k] < v[k + 3]))
      return std::string("the minimum corner must be below the maximum on every axis (") +
             "xyz"[k] + ": " + std::to_string(v[k]) + " >= " + std::to_string(v[k + 3]) + ")";
  return std::string();
}

}  // namespace drill_pipe_pose::tools
