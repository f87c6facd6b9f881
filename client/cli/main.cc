// meshgauge: shape diameter function of surface meshes from the command line.
// Usage errors exit 2, runtime errors 1 (one line "meshgauge: error: ...";
// under `remote`, the status code first: the server's, for a refusal),
// --help and --version 0.
#include <malloc.h>

#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/cli/backend.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "client/cli/huge_pages.h"
#include "client/cli/self_exe.h"

namespace meshgauge::cli {
namespace {

constexpr char kDescription[] =
    "meshgauge: local thickness of surface meshes (Shape Diameter Function), "
    "its exact derivatives, penalties and constraints; locally or through a "
    "meshgauge-server (remote).";
constexpr char kRemoteDescription[] =
    "the same verbs through a meshgauge-server, and its sessions";

// What a parsed verb will do.
using Run = std::function<absl::Status()>;

// A verb reading a mesh file: MESH plus the sdf, mesh and output flags.
CLI::App* MeshVerb(CLI::App& app, const char* name, const char* help,
                   MeshInput* in, bool files) {
  CLI::App* sub = app.add_subcommand(name, help);
  sub->fallthrough();  // under remote: --server etc. may follow the verb.
  sub->add_option("mesh", in->mesh, "mesh file (.obj .off .ply .stl)")
      ->required();
  AddSdfFlags(sub, &in->sdf);
  AddMeshFlags(sub, &in->mesh_flags);
  AddOutputFlags(sub, &in->out, files);
  return sub;
}

#if MESHGAUGE_CLI_REMOTE
// A remote verb on the sessions, with --json.
CLI::App* SessionVerb(CLI::App* remote, const char* name, const char* help,
                      RemoteInput* in, bool takes_id, Run* run) {
  CLI::App* sub = remote->add_subcommand(name, help);
  sub->fallthrough();  // --server etc. may follow the verb.
  if (takes_id) sub->add_option("id", in->target, "session id")->required();
  sub->add_flag("--json", in->json, "print the result as JSON");
  sub->callback([in, name, run] {
    in->verb = name;
    *run = [in] { return RunRemote(*in); };
  });
  return sub;
}
#endif

// The verbs computing on a mesh file, here or (remote) on a server.
struct MeshVerbs {
  MeshInput in;
  GradFlags grad;
  PenaltyFlags penalty;
  CalibrateFlags calibrate;
  ReportFlags report;
  GradcheckFlags check;
};

using BackendSource = std::function<absl::StatusOr<BackendFactory>()>;

// Adds sdf, grad, penalty, calibrate, report and gradcheck to `app`; after
// parsing, `backend` gives the backend they compute with.
void AddMeshVerbs(CLI::App& app, MeshVerbs* v, BackendSource backend,
                  Run* run) {
  auto with = [backend,
               run](std::function<absl::Status(const BackendFactory&)> verb) {
    return [backend, run, verb] {
      *run = [backend, verb]() -> absl::Status {
        auto make = backend();
        if (!make.ok()) return make.status();
        return verb(*make);
      };
    };
  };
  CLI::App* s = MeshVerb(app, "sdf",
                         "SDF per vertex or face (summary; --csv, --ply, "
                         "--json)",
                         &v->in, true);
  AddSamplesFlag(s, &v->in.sdf);
  s->callback(
      with([v](const BackendFactory& make) { return RunSdf(v->in, make); }));
  CLI::App* g = MeshVerb(app, "grad",
                         "sensitivities: --vjp FILE (g^T J), --jacobian FILE",
                         &v->in, false);
  AddGradFlags(g, &v->grad);
  AddSamplesFlag(g, &v->in.sdf);
  g->callback(with([v](const BackendFactory& make) {
    return RunGrad(v->in, v->grad, make);
  }));
  CLI::App* p = MeshVerb(app, "penalty",
                         "minimum-thickness penalty, or --form ks the "
                         "aggregated constraint, and its gradient",
                         &v->in, false);
  AddPenaltyFlags(p, &v->penalty, /*t_min_required=*/true);
  AddSamplesFlag(p, &v->in.sdf);
  p->callback(with([v](const BackendFactory& make) {
    return RunPenalty(v->in, v->penalty, make);
  }));
  CLI::App* c =
      MeshVerb(app, "calibrate", "SDF against physical thickness (SPEC §8)",
               &v->in, false);
  AddCalibrateFlags(c, &v->calibrate);
  c->callback(with([v](const BackendFactory& make) {
    return RunCalibrate(v->in, v->calibrate, make);
  }));
  CLI::App* r = MeshVerb(app, "report",
                         "where it is thinner than --t-min: pictures, thin "
                         "regions, a web page and a coloured PLY in --out",
                         &v->in, false);
  AddReportFlags(r, &v->report);
  AddSamplesFlag(r, &v->in.sdf);
  r->callback(with([v](const BackendFactory& make) {
    return RunReport(v->in, v->report, make);
  }));
  CLI::App* gc = MeshVerb(app, "gradcheck",
                          "check the derivatives by central differences "
                          "(exit 1 on FAIL or INCONCLUSIVE)",
                          &v->in, false);
  AddGradcheckFlags(gc, &v->check, &v->in.sdf);
  AddPenaltyFlags(gc, &v->penalty, /*t_min_required=*/false);
  gc->callback(with([v](const BackendFactory& make) {
    return RunGradcheck(v->in, v->check, v->penalty, make);
  }));
}

// "unknown verb 'X' (verbs: ...)" when the first argument of `app` (argv
// from `first`) is neither a flag nor one of its verbs; empty otherwise.
std::string UnknownVerb(CLI::App& app, int argc, char** argv, int first) {
  if (first >= argc || argv[first][0] == '-') return "";
  std::vector<std::string> verbs;
  for (const CLI::App* sub : app.get_subcommands({})) {
    if (sub->get_name() == argv[first]) {
      return sub->get_name() == "remote"
                 ? UnknownVerb(*app.get_subcommand("remote"), argc, argv,
                               first + 1)
                 : "";
    }
    verbs.push_back(sub->get_name());
  }
  return absl::StrCat("unknown verb '", argv[first],
                      "' (verbs: ", absl::StrJoin(verbs, ", "), ")");
}

}  // namespace

int Main(int argc, char** argv) {
  CLI::App app(kDescription, "meshgauge");
  app.set_version_flag("--version", std::string("meshgauge ") +
                                        MESHGAUGE_VERSION + " (" +
                                        MESHGAUGE_BUILD_TYPE + " build)");
  app.set_help_all_flag("--help-all", "every verb's flags");
  app.require_subcommand(1);
  Run run;

  MeshVerbs local;
  AddMeshVerbs(
      app, &local,
      [&local] {
        return absl::StatusOr<BackendFactory>(
            LocalBackend(local.in.out.Progress(), local.in.sdf.threads));
      },
      &run);

  ShapeInput shape;
  CLI::App* sh = app.add_subcommand("shape", "write an analytic test shape");
  sh->add_option("kind", shape.kind, "circle|sphere|torus|hollow")
      ->required()
      ->check(CLI::IsMember({"circle", "sphere", "torus", "hollow"}));
  sh->add_option("--out", shape.out, "output OBJ file")->required();
  sh->add_option("--size", shape.size, "element size, > 0")
      ->check(Positive())
      ->capture_default_str();
  sh->add_option("--radius", shape.radius, "radius, > 0")
      ->check(Positive())
      ->capture_default_str();
  sh->callback([&] { run = [&] { return RunShape(shape); }; });

#if MESHGAUGE_CLI_REMOTE
  RemoteInput r;
  CLI::App* remote = app.add_subcommand("remote", kRemoteDescription);
  remote->require_subcommand(1);
  AddRemoteFlags(remote, &r.remote);
  MeshVerbs remote_verbs;
  std::string remote_session;
  int remote_fan_out = 1;
  AddMeshVerbs(
      *remote, &remote_verbs,
      [&] {
        return RemoteBackend(r.remote, remote_session,
                             remote_verbs.in.out.Progress(), remote_fan_out);
      },
      &run);
  for (const char* verb :
       {"sdf", "grad", "penalty", "calibrate", "report", "gradcheck"}) {
    remote->get_subcommand(verb)->add_option(
        "--session-id", remote_session,
        "compute on this session (kept; created from MESH if missing) "
        "instead of a temporary one");
  }
  for (const char* verb : {"sdf", "grad", "penalty"}) {
    remote->get_subcommand(verb)
        ->add_option("--fan-out", remote_fan_out,
                     "split the pass (and the VJP or penalty) into K sample "
                     "ranges sent at once, through a balancer to K replicas; "
                     "the same bits for any K")
        ->check(CLI::Range(1, 1024))
        ->capture_default_str();
  }
  CLI::App* up = SessionVerb(remote, "upload", "upload MESH as a session", &r,
                             false, &run);
  up->add_option("mesh", r.target, "mesh file")->required();
  up->add_option("--session-id", r.session_id,
                 "session id (default: a new UUID)");
  AddMeshFlags(up, &r.mesh_flags);
  AddThreadsFlag(up, &r.threads,
                 "threads of the local checks before the upload (0: all "
                 "cores)");
  SessionVerb(remote, "list", "the caller's sessions", &r, false, &run);
  SessionVerb(remote, "health", "exit 0 only while SERVING", &r, false, &run);
  SessionVerb(remote, "server-info",
              "the server's release and the limits the caller meets", &r, false,
              &run);
  SessionVerb(remote, "info", "every SessionInfo field", &r, true, &run);
  SessionVerb(remote, "delete", "delete a session", &r, true, &run);
  CLI::App* upd =
      SessionVerb(remote, "update", "move the vertices", &r, true, &run);
  upd->add_option("--positions", r.positions,
                  "mesh file with the new positions (same vertex count)")
      ->required();
  upd->add_option("--generation", r.generation,
                  "expected generation (-1: the current)")
      ->capture_default_str();
  // Also after the verb, and in its --help.
  for (CLI::App* sub : remote->get_subcommands({})) {
    AddRemoteFlags(sub, &r.remote);
  }
#else
  // Listed for --help only: main() hands `meshgauge remote ...` to
  // meshgauge-remote before anything is parsed.
  CLI::App* remote = app.add_subcommand("remote", kRemoteDescription);
#endif

  if (const std::string unknown = UnknownVerb(app, argc, argv, 1);
      !unknown.empty()) {
    std::cerr << "meshgauge: usage error: " << unknown
              << "\nRun 'meshgauge --help' or 'meshgauge VERB --help'.\n";
    return 2;
  }
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
    // A remote caller tells a refusal (UNAUTHENTICATED, RESOURCE_EXHAUSTED)
    // from a server gone (UNAVAILABLE) by its code.
    std::cerr << "meshgauge: error: "
              << (remote->parsed()
                      ? status.ToString(
                            absl::StatusToStringMode::kWithNoExtraData)
                      : std::string(status.message()))
              << "\n";
    return 1;
  }
  return 0;
}

}  // namespace meshgauge::cli

#if !MESHGAUGE_CLI_REMOTE
namespace meshgauge::cli {

// The remote verbs, and the help listing every verb, live in
// meshgauge-remote beside this program, so that the local verbs do not
// load gRPC at start-up (docs/benchmarks.md, "Issue 52's run"). When the
// first argument that is not a flag is `remote`, or --help-all comes before
// it, this process becomes meshgauge-remote with the same arguments (with
// the huge-page tunable already set for a large file, so that it does not
// re-execute itself). Returns the exit code when that fails (1, the status
// first, as remote errors are printed), or -1 to go on here: no remote
// verb, or --help-all without meshgauge-remote (the local verbs' help).
int HandOverRemoteVerbs(int argc, char** argv) {
  bool help_all = false, remote = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--help-all") help_all = true;
    if (!arg.empty() && arg[0] == '-') continue;
    remote = arg == "remote";
    break;
  }
  if (!remote && !help_all) return -1;
  if (ArgumentNamesFileOfAtLeast(argv, kHugePagesFileBytes)) {
    SetHugePagesTunable();
  }
  const absl::Status s = ExecSibling("meshgauge-remote", argv);
  if (!remote) return -1;
  std::cerr << "meshgauge: error: "
            << s.ToString(absl::StatusToStringMode::kWithNoExtraData) << "\n";
  return 1;
}

}  // namespace meshgauge::cli
#endif

int main(int argc, char** argv) {
#if !MESHGAUGE_CLI_REMOTE
  if (const int code = meshgauge::cli::HandOverRemoteVerbs(argc, argv);
      code >= 0) {
    return code;
  }
#endif
  // Transparent huge pages when an argument names a file of 4 MiB or more
  // (client/cli/huge_pages.h; docs/benchmarks.md): on a million-vertex mesh
  // read 0.59 -> 0.16 s, checks 0.90 -> 0.43 s, setup 0.69 -> 0.52 s.
  if (meshgauge::cli::ArgumentNamesFileOfAtLeast(
          argv, meshgauge::cli::kHugePagesFileBytes)) {
    meshgauge::cli::ReexecWithHugePages(argv);
  }
  // A run allocates and frees arrays of megabytes stage after stage (file,
  // diagnostics, topology, normals): kept in the heap instead of unmapped,
  // each is reused without faulting its pages in again (measured on igea:
  // the mesh copy, topology and normals stop faulting, about 0.1 s). 32 MiB
  // is glibc's largest threshold; the process exits after its verb.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  return meshgauge::cli::Main(argc, argv);
}
