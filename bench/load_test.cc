// meshgauge-load: N concurrent optimiser-like clients against a server.
//
//   meshgauge-load --target host:port [--clients N] [--iterations M]
//                  [--frequency F] [--time_limit_seconds T] [--recreate]
//                  [--until_signal]
//
// Every client creates its own session (an icosphere of geodesic frequency
// F), then for M iterations: UpdatePositions (a deterministic deformation of
// iteration i) -> ComputeSdf -> ComputeVjp (g = 1) on even iterations,
// ComputePenalty with its gradient on odd ones. First one client runs
// the same sequence alone: the reference. Every reply of every concurrent
// client must equal the reference bit for bit. Bounded by --iterations and
// --time_limit_seconds; loopback or the stack's own addresses only.
// With --until_signal the clients go on past M iterations, the positions
// cycling through the reference's M (SPEC §3, v2.1: a reply does not depend
// on the session's history), until SIGTERM or SIGINT: each client then ends
// its iteration and stops (a fault test ends the load once its fault is
// over, whatever the fault's length).
// With --fan_out K > 1 (the big-client mode, usually with --clients 1 and a
// large --frequency) the concurrent clients split each ComputeSdf,
// ComputeVjp and ComputePenalty into K sample ranges sent at once (through
// a balancer, to K replicas; docs/server.md, Fan-out) while the reference
// makes single calls: every fanned-out reply must still be the reference's
// bit for bit, and the run prints the time per iteration of both and their
// ratio ("big client: ... speed-up").
// With --recreate, a client whose session was lost (NOT_FOUND, UNAVAILABLE:
// a replica died) re-creates it at the current iteration and continues.
// At the end every client checks that its session is still there at its
// last generation (else it was lost). Prints "concurrent phase: started"
// when the clients start and, with --progress_every K, "iterations: N" after
// every K-th iteration (tests inject their faults while calls flow),
// throughput, p50/p95/p99/max latency per RPC, errors by status code,
// mismatches and lost sessions; exits 0 iff there were no mismatches, no
// lost sessions, no call slower than --max_latency_seconds (when given) and
// (without --recreate) no errors, or (with --recreate) every client
// finished.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/str_cat.h"
#include "client/remote/remote_client.h"
#include "lib/core/shapes.h"
#include "lib/core/stopwatch.h"
#include "server/flags_help.h"

ABSL_FLAG(std::string, target, "127.0.0.1:50051", "server or balancer");
ABSL_FLAG(int, clients, 4, "concurrent clients, 1..256");
ABSL_FLAG(int, iterations, 5, "iterations per client, 1..10000");
ABSL_FLAG(int, frequency, 12,
          "icosphere frequency (10 F^2 + 2 vertices), 1..1000");
ABSL_FLAG(int, fan_out, 1,
          "the concurrent clients split each pass, VJP and penalty into K "
          "sample ranges (1..64; the reference does not)");
ABSL_FLAG(double, time_limit_seconds, 300, "stop starting iterations after");
ABSL_FLAG(bool, until_signal, false,
          "iterate until SIGTERM or SIGINT, the positions cycling through "
          "the --iterations of the reference");
ABSL_FLAG(bool, recreate, false, "re-create lost sessions and continue");
ABSL_FLAG(std::string, session_prefix, "load", "session ids: PREFIX-<n>");
ABSL_FLAG(bool, retry, true,
          "the clients' gRPC retry policy (false: every UNAVAILABLE is an "
          "error)");
ABSL_FLAG(int, progress_every, 0,
          "print \"iterations: N\" after every K-th concurrent iteration "
          "(K; 0: never)");
ABSL_FLAG(double, max_latency_seconds, 0,
          "fail if any call took longer, retries included (0: no bound)");
ABSL_FLAG(std::string, tls_ca_file, "", "connect with TLS, trusting this CA");
ABSL_FLAG(std::string, token_file, "",
          "bearer token file (default: MESHGAUGE_TOKEN)");

namespace meshgauge::bench {
namespace {

// --time_limit_seconds, counted from the start of the run.
struct TimeLimit {
  Stopwatch since_start{};
  double seconds = 0;
  bool Passed() const { return since_start.Seconds() > seconds; }
};

// Set by SIGTERM or SIGINT with --until_signal.
std::atomic<bool> stop_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free);
void RequestStop(int) { stop_requested = true; }

struct Reply {
  std::vector<double> values;
  std::vector<double> gradient;
};

struct Stats {
  std::mutex mu;
  std::map<std::string, int64_t> client_errors;        // session id -> errors.
  std::map<std::string, std::vector<double>> latency;  // per RPC, seconds.
  std::map<std::string, int64_t> errors;               // "RPC CODE" -> n.
  std::map<std::string, std::string> first_message;    // "RPC CODE" -> text.
  int64_t mismatches = 0, iterations = 0, recreated = 0, lost = 0;
  void Latency(const std::string& rpc, double s) {
    std::lock_guard<std::mutex> l(mu);
    latency[rpc].push_back(s);
  }
  void Error(const std::string& client, const std::string& rpc,
             const absl::Status& st) {
    std::lock_guard<std::mutex> l(mu);
    ++client_errors[client];
    const std::string key =
        absl::StrCat(rpc, " ", absl::StatusCodeToString(st.code()));
    if (++errors[key] == 1) first_message[key] = std::string(st.message());
  }
  // One line per "RPC CODE": the count and the first message.
  void PrintErrors() const {
    for (const auto& [key, n] : errors) {
      std::printf("  %s: %lld (first: %s)\n", key.c_str(),
                  static_cast<long long>(n), first_message.at(key).c_str());
    }
  }
};

std::vector<Vec3> Deform(const Mesh& mesh, int iteration) {
  std::vector<Vec3> p = mesh.positions;
  const double a = 0.02 * std::sin(0.7 * (iteration + 1));
  for (Vec3& v : p) v = Vec3(v.x * (1 + a), v.y * (1 - a), v.z * (1 + a * v.x));
  return p;
}

void AppendCoordinates(const std::vector<Vec3>& v, std::vector<double>* out) {
  for (const Vec3& p : v) out->insert(out->end(), {p.x, p.y, p.z});
}

bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() ||
          std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// One client's run: `iterations` of them, or with `until_signal` until
// stop_requested (iteration i at the positions of i % iterations). Fills
// `replies` when `reference` is null, else compares. Returns false when the
// client could not finish.
bool RunClient(const std::string& target, const client::ClientOptions& options,
               const std::string& id, const Mesh& mesh, int iterations,
               bool until_signal, int fan_out, const TimeLimit& limit,
               std::vector<Reply>* replies, const std::vector<Reply>* reference,
               Stats& stats) {
  client::RemoteClient c(target, options);
  const SdfParams params;
  const std::vector<double> ones(mesh.num_vertices(), 1.0);
  auto timed = [&](const char* rpc, auto call) {
    const Stopwatch watch;
    auto r = call();
    const double s = watch.Seconds();
    if (r.ok())
      stats.Latency(rpc, s);
    else
      stats.Error(id, rpc, r.status());
    return r;
  };
  auto create = [&](const std::vector<Vec3>& positions) {
    Mesh m = mesh;
    m.positions = positions;
    (void)c.Delete(id);  // a leftover from an earlier run, if any.
    return timed("CreateSession", [&] { return c.Upload(m, id); }).ok();
  };
  if (!create(mesh.positions)) return false;
  int64_t generation = 0;
  for (int it = 0; until_signal ? !stop_requested : it < iterations; ++it) {
    if (limit.Passed()) return false;
    const int step = it % iterations;
    const std::vector<Vec3> positions = Deform(mesh, step);
    bool lost = false;
    auto up = timed("UpdatePositions", [&] {
      return c.UpdatePositions(id, generation, 3, positions);
    });
    absl::StatusOr<wire::SdfReply> sdf = absl::UnknownError("not run");
    absl::Status derivative = absl::UnknownError("not run");
    std::vector<double> gradient;
    if (up.ok()) {
      generation = up->generation;
      // The session's mesh, for a fanned-out call's merged summary only.
      std::optional<Mesh> moved;
      if (fan_out > 1) {
        moved = mesh;
        moved->positions = positions;
      }
      sdf = timed("ComputeSdf", [&] {
        return c.ComputeSdf(id, params,
                            {.fan_out = fan_out,
                             .mesh = moved ? &*moved : nullptr});
      });
      if (sdf.ok() && step % 2 == 0) {
        auto vjp = timed("ComputeVjp", [&] {
          return c.ComputeVjp(id, params, ones, std::nullopt, fan_out);
        });
        derivative = vjp.status();
        if (vjp.ok()) AppendCoordinates(vjp->gradient, &gradient);
      } else if (sdf.ok()) {
        auto pen = timed("ComputePenalty", [&] {
          return c.ComputePenalty(id, params, {.t_min = 2.5}, true,
                                  std::nullopt, fan_out, sdf->result.values);
        });
        derivative = pen.status();
        if (pen.ok()) {
          AppendCoordinates(pen->penalty.gradient, &gradient);
          gradient.push_back(pen->penalty.value);
        }
      }
    }
    const absl::Status failed =
        !up.ok() ? up.status() : (!sdf.ok() ? sdf.status() : derivative);
    if (!failed.ok()) {
      lost = failed.code() == absl::StatusCode::kNotFound ||
             failed.code() == absl::StatusCode::kUnavailable;
      if (!(lost && absl::GetFlag(FLAGS_recreate))) return false;
      // Re-create from the original mesh and redo this iteration (which
      // moves it to this iteration's positions); the replies do not depend
      // on the session's history (SPEC §3, v2.1).
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      bool ok = false;
      for (int attempt = 0; attempt < 20 && !ok; ++attempt) {
        ok = create(mesh.positions);
        if (!ok) std::this_thread::sleep_for(std::chrono::milliseconds(250));
      }
      if (!ok) return false;
      {
        std::lock_guard<std::mutex> l(stats.mu);
        ++stats.recreated;
      }
      generation = 0;
      --it;  // redo this iteration on the new session.
      continue;
    }
    Reply reply{sdf->result.values, std::move(gradient)};
    std::lock_guard<std::mutex> l(stats.mu);
    ++stats.iterations;
    if (const int every = absl::GetFlag(FLAGS_progress_every);
        reference != nullptr && every > 0 && stats.iterations % every == 0) {
      std::printf("iterations: %lld\n",
                  static_cast<long long>(stats.iterations));
      std::fflush(stdout);
    }
    if (reference == nullptr) {
      replies->push_back(std::move(reply));
    } else if (!SameBits(reply.values, (*reference)[step].values) ||
               !SameBits(reply.gradient, (*reference)[step].gradient)) {
      ++stats.mismatches;
    }
  }
  // Still there, at the last generation: nothing was lost on the way.
  auto info = c.Get(id);
  if (!info.ok() || info->generation != generation) {
    std::lock_guard<std::mutex> l(stats.mu);
    ++stats.lost;
    if (!info.ok()) stats.Error(id, "GetSession", info.status());
  }
  (void)c.Delete(id);
  return true;
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

int Run() {
  const std::string target = absl::GetFlag(FLAGS_target);
  client::ClientOptions options;
  options.retry = absl::GetFlag(FLAGS_retry);
  if (absl::Status s =
          client::LoadClientSecrets(absl::GetFlag(FLAGS_tls_ca_file), "", "",
                                    absl::GetFlag(FLAGS_token_file), &options);
      !s.ok()) {
    std::printf("%s\n", std::string(s.message()).c_str());
    return 2;
  }
  const int clients = std::clamp(absl::GetFlag(FLAGS_clients), 1, 256);
  const int iterations = std::clamp(absl::GetFlag(FLAGS_iterations), 1, 10000);
  const Mesh mesh =
      MakeIcosphere(1, std::clamp(absl::GetFlag(FLAGS_frequency), 1, 1000));
  const int fan_out = std::clamp(absl::GetFlag(FLAGS_fan_out), 1, 64);
  const TimeLimit limit{.seconds = absl::GetFlag(FLAGS_time_limit_seconds)};
  const std::string prefix = absl::GetFlag(FLAGS_session_prefix);
  Stats ref_stats;
  std::vector<Reply> reference;
  const bool until_signal = absl::GetFlag(FLAGS_until_signal);
  if (until_signal) {
    std::signal(SIGTERM, RequestStop);
    std::signal(SIGINT, RequestStop);
  }
  const Stopwatch ref_watch;
  if (!RunClient(target, options, prefix + "-reference", mesh, iterations,
                 /*until_signal=*/false, /*fan_out=*/1, limit, &reference,
                 nullptr, ref_stats)) {
    std::printf("reference run failed\n");
    ref_stats.PrintErrors();
    return 1;
  }
  const double ref_seconds = ref_watch.Seconds();
  if (stop_requested) {  // the clients would make no iteration and pass.
    std::printf("stopped by a signal before the concurrent phase\n");
    return 1;
  }
  Stats stats;
  std::atomic<int> finished{0};
  std::printf("concurrent phase: started\n");
  std::fflush(stdout);
  const Stopwatch watch;
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back([&, i] {
      if (RunClient(target, options, absl::StrCat(prefix, "-", i), mesh,
                    iterations, until_signal, fan_out, limit, nullptr,
                    &reference, stats)) {
        ++finished;
      }
    });
  }
  for (auto& t : threads) t.join();
  const double wall = watch.Seconds();
  int64_t errors = 0;
  for (const auto& [k, n] : stats.errors) errors += n;
  const std::string per_client =
      until_signal
          ? absl::StrCat("iterations until signalled (cycling through ",
                         iterations, " positions)")
          : absl::StrCat(iterations, " iterations");
  std::printf("target %s: %d clients x %s, %lld vertices, %.2f s\n",
              target.c_str(), clients, per_client.c_str(),
              static_cast<long long>(mesh.num_vertices()), wall);
  std::printf(
      "throughput: %.2f iterations/s (%lld iterations), %d/%d clients "
      "finished, %lld sessions re-created\n",
      stats.iterations / wall, static_cast<long long>(stats.iterations),
      finished.load(), clients, static_cast<long long>(stats.recreated));
  std::printf(
      "| RPC | calls | p50 ms | p95 ms | p99 ms | max ms |\n| --- | --- | --- "
      "| --- | --- | --- |\n");
  const double bound = absl::GetFlag(FLAGS_max_latency_seconds);
  int64_t over_bound = 0;
  for (const auto& [rpc, v] : stats.latency) {
    std::printf("| %s | %zu | %.1f | %.1f | %.1f | %.1f |\n", rpc.c_str(),
                v.size(), 1e3 * Percentile(v, 0.5), 1e3 * Percentile(v, 0.95),
                1e3 * Percentile(v, 0.99), 1e3 * Percentile(v, 1.0));
    if (bound > 0) {
      over_bound +=
          std::ranges::count_if(v, [&](double t) { return t > bound; });
    }
  }
  if (bound > 0) {
    std::printf("calls slower than %.1f s: %lld\n", bound,
                static_cast<long long>(over_bound));
  }
  if (fan_out > 1 && stats.iterations > 0) {
    // Per client: its iterations took the wall time; the reference's took
    // ref_seconds (its upload included, as each client's is).
    const double mine = wall * clients / stats.iterations;
    const double single = ref_seconds / iterations;
    std::printf(
        "big client: fan-out %d: %.3f s per iteration, the single-call "
        "reference %.3f s: speed-up %.2f\n",
        fan_out, mine, single, single / mine);
  }
  std::printf("errors: %lld\n", static_cast<long long>(errors));
  stats.PrintErrors();
  int untouched = 0;
  for (int i = 0; i < clients; ++i) {
    untouched += stats.client_errors.count(absl::StrCat(prefix, "-", i)) == 0;
  }
  std::printf("clients without any error: %d/%d\n", untouched, clients);
  std::printf("mismatches against the single-client reference: %lld\n",
              static_cast<long long>(stats.mismatches));
  int64_t calls = 0;
  for (const auto& [rpc, v] : stats.latency) calls += std::ssize(v);
  std::printf("calls: %lld ok, %lld failed; sessions lost: %lld\n",
              static_cast<long long>(calls), static_cast<long long>(errors),
              static_cast<long long>(stats.lost));
  const bool pass =
      stats.mismatches == 0 && stats.lost == 0 && over_bound == 0 &&
      (absl::GetFlag(FLAGS_recreate) ? finished == clients
                                     : errors == 0 && finished == clients);
  std::printf("%s\n", pass ? "PASS" : "FAIL");
  return pass ? 0 : 1;
}

}  // namespace
}  // namespace meshgauge::bench

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "meshgauge-load --target HOST:PORT [--clients N] [--iterations M] ...");
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/load_test.cc");
  absl::ParseCommandLine(argc, argv);
  return meshgauge::bench::Run();
}
