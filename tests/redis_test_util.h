// A private redis-server for a test: its own port and AOF directory,
// started and stopped (or killed) by the test.
#pragma once

#include <gtest/gtest.h>
#include <hiredis/hiredis.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

namespace meshgauge::testing {

// A loopback port free right now.
inline int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  close(fd);
  return ntohs(addr.sin_port);
}

class RedisProcess {
 public:
  RedisProcess() : port_(FreePort()) {
    char tmpl[] = "/tmp/meshgauge-redis-XXXXXX";
    dir_ = mkdtemp(tmpl);
  }
  ~RedisProcess() {
    Stop(SIGKILL);
    std::filesystem::remove_all(dir_);
  }
  int port() const { return port_; }
  std::string url() const {
    return "redis://127.0.0.1:" + std::to_string(port_);
  }

  // Starts redis-server with AOF (fsync always) and waits for PING.
  void Start() {
    pid_ = fork();
    if (pid_ == 0) {
      const std::string port = std::to_string(port_);
      execlp("redis-server", "redis-server", "--port", port.c_str(), "--bind",
             "127.0.0.1", "--dir", dir_.c_str(), "--appendonly", "yes",
             "--appendfsync", "always", "--save", "", "--logfile",
             (dir_ + "/redis.log").c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    for (int i = 0; i < 200; ++i) {
      if (Ping()) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    FAIL() << "redis-server did not answer on port " << port_;
  }
  // SIGKILL: a crash; SIGTERM: a clean stop.
  void Stop(int sig) {
    if (pid_ <= 0) return;
    kill(pid_, sig);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  bool Ping() const {
    const std::vector<std::string> r = Command({"PING"});
    return r.size() == 1 && r[0] == "PONG";
  }
  // Calls of EVAL and EVALSHA so far (INFO commandstats): the store's round
  // trips, each a script.
  int64_t ScriptCalls() const {
    const std::vector<std::string> r = Command({"INFO", "commandstats"});
    int64_t n = 0;
    for (const std::string key :
         {"cmdstat_eval:calls=", "cmdstat_evalsha:calls="}) {
      if (r.empty()) break;
      if (auto at = r[0].find(key); at != std::string::npos) {
        n += std::stoll(r[0].substr(at + key.size()));
      }
    }
    return n;
  }
  // Runs one command on a new connection and returns the strings of its
  // reply (an array's elements, or the one string or status); nothing when
  // Redis cannot be reached.
  std::vector<std::string> Command(const std::vector<std::string>& argv) const {
    timeval tv{1, 0};
    redisContext* c = redisConnectWithTimeout("127.0.0.1", port_, tv);
    std::vector<std::string> out;
    if (c && !c->err) {
      std::vector<const char*> args;
      std::vector<size_t> lengths;
      for (const std::string& a : argv) {
        args.push_back(a.data());
        lengths.push_back(a.size());
      }
      auto* r = static_cast<redisReply*>(redisCommandArgv(
          c, static_cast<int>(args.size()), args.data(), lengths.data()));
      auto put = [&out](const redisReply* e) {
        if (e->type == REDIS_REPLY_STRING || e->type == REDIS_REPLY_STATUS) {
          out.emplace_back(e->str, e->len);
        }
      };
      if (r && r->type == REDIS_REPLY_ARRAY) {
        for (size_t i = 0; i < r->elements; ++i) put(r->element[i]);
      } else if (r) {
        put(r);
      }
      if (r) freeReplyObject(r);
    }
    if (c) redisFree(c);
    return out;
  }

 private:
  int port_;
  std::string dir_;
  pid_t pid_ = -1;
};

}  // namespace meshgauge::testing
