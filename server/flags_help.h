// --help for the absl-flag programs (meshgauge-server, meshgauge-load).
//
// absl lists under --help only the flags defined in a file named after the
// program (meshgauge-server.cc, meshgauge-server_main.cc, ...); ours define
// theirs in server/main.cc and bench/load_test.cc, so --help printed "No
// flags matched." and exited 1. ListOwnFlagsInHelp makes absl's --help,
// --helpshort and --helppackage select the flags of the program's own file,
// and answers --help and --helpshort itself: the usage message and each of
// those flags with its help and default, on stdout, exit 0 (absl exits 1).
// Header-only: both programs link absl's flags libraries, nothing else.
#pragma once

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "absl/flags/commandlineflag.h"
#include "absl/flags/reflection.h"
#include "absl/flags/usage.h"
#include "absl/flags/usage_config.h"
#include "absl/strings/match.h"
#include "absl/strings/string_view.h"

namespace meshgauge {

// The help text of the flags defined in a file whose path ends with
// `flags_file` (e.g. "server/main.cc"), sorted by name: "  --NAME (HELP);
// default: VALUE;" (strings quoted), as absl prints them.
inline std::string OwnFlagsHelp(absl::string_view flags_file) {
  std::vector<std::pair<std::string, std::string>> lines;
  for (const auto& [name, flag] : absl::GetAllFlags()) {
    if (!absl::EndsWith(flag->Filename(), flags_file)) continue;
    const std::string value = flag->DefaultValue();
    const bool quoted = flag->IsOfType<std::string>();
    lines.emplace_back(
        std::string(name),
        "    --" + std::string(name) + " (" + flag->Help() +
            "); default: " + (quoted ? "\"" + value + "\"" : value) + ";\n");
  }
  std::sort(lines.begin(), lines.end());
  std::string out;
  for (const auto& line : lines) out += line.second;
  return out;
}

// Call after absl::SetProgramUsageMessage and before
// absl::ParseCommandLine. `flags_file`: the end of the path of the file
// that defines the program's flags. `version`: --version's text (null:
// absl's default). On --help or --helpshort (any spelling absl accepts
// without a value: -help, --help, -helpshort, --helpshort) prints the usage
// message and the program's flags and exits 0.
inline void ListOwnFlagsInHelp(int argc, char** argv,
                               absl::string_view flags_file,
                               std::function<std::string()> version = nullptr) {
  static std::string* file = new std::string(flags_file);
  auto own = [](absl::string_view filename) {
    return absl::EndsWith(filename, *file);
  };
  absl::FlagsUsageConfig config;
  config.contains_helpshort_flags = own;
  config.contains_help_flags = own;
  config.contains_helppackage_flags = own;
  if (version) config.version_string = version;
  absl::SetFlagsUsageConfig(config);
  for (int i = 1; i < argc; ++i) {
    const absl::string_view arg = argv[i];
    if (arg == "--") break;
    if (arg == "--help" || arg == "-help" || arg == "--helpshort" ||
        arg == "-helpshort") {
      std::cout << argv[0] << ": " << absl::ProgramUsageMessage() << "\n\n"
                << "  Flags from " << flags_file << ":\n"
                << OwnFlagsHelp(flags_file) << "\n"
                << "Try --helpfull to get a list of all flags (absl's "
                   "included) or --help=substring for the flags whose name, "
                   "help or file includes substring.\n";
      std::cout.flush();
      std::exit(0);
    }
  }
}

}  // namespace meshgauge
