// meshgauge: shape diameter function of surface meshes from the command line.
// Usage errors exit 2, runtime errors 1 (one line "meshgauge: error: ..."),
// --help and --version 0.
#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <string>

#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"

namespace meshgauge::cli {
namespace {

constexpr char kDescription[] =
    "meshgauge: local thickness of surface meshes (Shape Diameter Function), "
    "its exact derivatives, penalties and constraints; locally or through a "
    "meshgauge-server (remote).";

// A verb reading a mesh file: MESH plus the sdf, mesh and output flags.
CLI::App* MeshVerb(CLI::App& app, const char* name, const char* help,
                   MeshInput* in, bool files) {
  CLI::App* sub = app.add_subcommand(name, help);
  sub->add_option("mesh", in->mesh, "mesh file (.obj .off .ply .stl)")
      ->required();
  AddSdfFlags(sub, &in->sdf);
  AddMeshFlags(sub, &in->mesh_flags);
  AddOutputFlags(sub, &in->out, files);
  return sub;
}

// A remote verb on a session id, with the sdf flags and --json.
CLI::App* RemoteVerb(CLI::App* remote, const char* name, const char* help,
                     RemoteInput* in, bool takes_id, bool sdf) {
  CLI::App* sub = remote->add_subcommand(name, help);
  sub->fallthrough();  // --server etc. may follow the verb.
  if (takes_id) sub->add_option("id", in->target, "session id")->required();
  if (sdf) AddSdfFlags(sub, &in->in.sdf);
  AddOutputFlags(sub, &in->in.out, false);
  sub->callback([in, name] { in->verb = name; });
  return sub;
}

}  // namespace

int Main(int argc, char** argv) {
  CLI::App app(kDescription, "meshgauge");
  app.set_version_flag("--version",
                       std::string("meshgauge ") + MESHGAUGE_VERSION + " (" +
                           MESHGAUGE_BUILD_TYPE + " build)");
  app.set_help_all_flag("--help-all", "every verb's flags");
  app.require_subcommand(1);
  std::function<absl::Status()> run;

  MeshInput in;
  GradFlags grad;
  PenaltyFlags penalty;
  CalibrateFlags calibrate;
  GradcheckFlags check;
  MeshVerb(app, "sdf", "SDF per vertex (summary; --csv, --ply, --json)", &in,
           true)
      ->callback([&] { run = [&] { return RunSdf(in); }; });
  CLI::App* g = MeshVerb(app, "grad",
                         "sensitivities: --vjp FILE (g^T J), --jacobian FILE",
                         &in, false);
  AddGradFlags(g, &grad);
  g->callback([&] { run = [&] { return RunGrad(in, grad); }; });
  CLI::App* p = MeshVerb(app, "penalty",
                         "minimum-thickness penalty, or --form ks the "
                         "aggregated constraint, and its gradient",
                         &in, false);
  AddPenaltyFlags(p, &penalty, /*t_min_required=*/true);
  p->callback([&] { run = [&] { return RunPenalty(in, penalty); }; });
  CLI::App* c = MeshVerb(app, "calibrate",
                         "SDF against physical thickness (SPEC §8)", &in,
                         false);
  AddCalibrateFlags(c, &calibrate);
  c->callback([&] { run = [&] { return RunCalibrate(in, calibrate); }; });
  CLI::App* gc = MeshVerb(app, "gradcheck",
                          "check the derivatives by central differences "
                          "(exit 1 on FAIL)",
                          &in, false);
  AddGradcheckFlags(gc, &check);
  AddPenaltyFlags(gc, &penalty, /*t_min_required=*/false);
  gc->callback([&] { run = [&] { return RunGradcheck(in, check, penalty); }; });

  ShapeInput shape;
  CLI::App* sh = app.add_subcommand("shape", "write an analytic test shape");
  sh->add_option("kind", shape.kind, "circle|sphere|torus|hollow")
      ->required()
      ->check(CLI::IsMember({"circle", "sphere", "torus", "hollow"}));
  sh->add_option("--out", shape.out, "output OBJ file")->required();
  sh->add_option("--size", shape.size, "element size")->capture_default_str();
  sh->add_option("--radius", shape.radius, "radius")->capture_default_str();
  sh->callback([&] { run = [&] { return RunShape(shape); }; });

  RemoteInput r;
  CLI::App* remote = app.add_subcommand(
      "remote", "the same work through a meshgauge-server");
  remote->require_subcommand(1);
  AddRemoteFlags(remote, &r.remote);
  CLI::App* up = remote->add_subcommand("upload", "upload MESH as a session");
  up->fallthrough();
  up->add_option("mesh", r.target, "mesh file")->required();
  up->add_option("--session-id", r.session_id,
                 "session id (default: server-assigned)");
  AddMeshFlags(up, &r.in.mesh_flags);
  AddOutputFlags(up, &r.in.out, false);
  up->callback([&] { r.verb = "upload"; });
  RemoteVerb(remote, "list", "the caller's sessions", &r, false, false);
  RemoteVerb(remote, "health", "exit 0 only while SERVING", &r, false, false);
  RemoteVerb(remote, "info", "every SessionInfo field", &r, true, false);
  RemoteVerb(remote, "delete", "delete a session", &r, true, false);
  RemoteVerb(remote, "sdf", "SDF of a session (--csv)", &r, true, true)
      ->add_option("--csv", r.in.out.csv, "per-vertex CSV");
  AddGradFlags(RemoteVerb(remote, "grad", "g^T J of a session", &r, true, true),
               &r.grad);
  AddPenaltyFlags(
      RemoteVerb(remote, "penalty", "penalty or constraint", &r, true, true),
      &r.penalty, /*t_min_required=*/true);
  AddCalibrateFlags(
      RemoteVerb(remote, "calibrate", "calibration report", &r, true, true),
      &r.calibrate);
  CLI::App* upd =
      RemoteVerb(remote, "update", "move the vertices", &r, true, false);
  upd->add_option("--positions", r.positions,
                  "mesh file with the new positions (same vertex count)")
      ->required();
  upd->add_option("--generation", r.generation,
                  "expected generation (-1: the current)")
      ->capture_default_str();
  remote->callback([&] { run = [&] { return RunRemote(r); }; });

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "meshgauge: usage error: " << e.what()
              << "\nRun 'meshgauge --help' or 'meshgauge VERB --help'.\n";
    return 2;
  }
  const absl::Status status = run();
  if (!status.ok()) {
    std::cerr << "meshgauge: error: " << status.message() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace meshgauge::cli

int main(int argc, char** argv) { return meshgauge::cli::Main(argc, argv); }
