// meshgauge: shape diameter function of surface meshes from the command line.
#include <iostream>
#include <string>
#include <vector>

#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"

namespace {

constexpr char kUsage[] =
    "meshgauge VERB [args] [flags]\n"
    "  sdf MESH        SDF per vertex (summary; --csv, --ply, --json)\n"
    "  grad MESH       sensitivities: --vjp FILE (g^T J), --jacobian FILE\n"
    "  penalty MESH    minimum-thickness penalty --t-min T [--grad FILE]\n"
    "                  (--form ks: the aggregated constraint, --rho R)\n"
    "  gradcheck MESH  check derivatives by finite differences [--samples N]\n"
    "  calibrate MESH  SDF vs physical thickness --t-min T\n"
    "  shape KIND      write an analytic shape: circle|sphere|torus|hollow\n"
    "  remote VERB     upload|list|info|delete|sdf|grad|penalty|update via\n"
    "                  a meshgauge-server (--server host:port)\n"
    "Run 'meshgauge --helpfull' for every flag.";

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(kUsage);
  std::vector<std::string> normalized =
      meshgauge::cli::NormalizeArgs(argc, argv);
  std::vector<char*> ptrs;
  for (std::string& s : normalized) ptrs.push_back(s.data());
  std::vector<char*> positional =
      absl::ParseCommandLine(static_cast<int>(ptrs.size()), ptrs.data());
  if (positional.size() < 2) {
    std::cerr << kUsage << "\n";
    return 2;
  }
  const std::string verb = positional[1];
  const std::vector<std::string> args(positional.begin() + 2, positional.end());
  absl::Status status;
  if (verb == "sdf") {
    status = meshgauge::cli::RunSdf(args);
  } else if (verb == "grad") {
    status = meshgauge::cli::RunGrad(args);
  } else if (verb == "penalty") {
    status = meshgauge::cli::RunPenalty(args);
  } else if (verb == "gradcheck") {
    status = meshgauge::cli::RunGradcheck(args);
  } else if (verb == "calibrate") {
    status = meshgauge::cli::RunCalibrate(args);
  } else if (verb == "remote") {
    status = meshgauge::cli::RunRemote(args);
  } else if (verb == "shape") {
    status = meshgauge::cli::RunShape(args);
  } else {
    std::cerr << "meshgauge: unknown verb '" << verb << "'\n" << kUsage << "\n";
    return 2;
  }
  if (!status.ok()) {
    std::cerr << "meshgauge: error: " << status.message() << "\n";
    return 1;
  }
  return 0;
}
