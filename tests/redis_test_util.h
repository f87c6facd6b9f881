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
    timeval tv{0, 200000};
    redisContext* c = redisConnectWithTimeout("127.0.0.1", port_, tv);
    bool ok = false;
    if (c && !c->err) {
      auto* r = static_cast<redisReply*>(redisCommand(c, "PING"));
      ok = r && r->type == REDIS_REPLY_STATUS;
      if (r) freeReplyObject(r);
    }
    if (c) redisFree(c);
    return ok;
  }
  // Calls of EVAL and EVALSHA so far (INFO commandstats): the store's round
  // trips, each a script.
  int64_t ScriptCalls() const {
    timeval tv{1, 0};
    redisContext* c = redisConnectWithTimeout("127.0.0.1", port_, tv);
    int64_t n = 0;
    if (c && !c->err) {
      auto* r = static_cast<redisReply*>(redisCommand(c, "INFO commandstats"));
      if (r && r->type == REDIS_REPLY_STRING) {
        const std::string info(r->str, r->len);
        for (const std::string key :
             {"cmdstat_eval:calls=", "cmdstat_evalsha:calls="}) {
          if (auto at = info.find(key); at != std::string::npos) {
            n += std::stoll(info.substr(at + key.size()));
          }
        }
      }
      if (r) freeReplyObject(r);
    }
    if (c) redisFree(c);
    return n;
  }

 private:
  int port_;
  std::string dir_;
  pid_t pid_ = -1;
};

}  // namespace meshgauge::testing
