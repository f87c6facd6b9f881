// A throw-away PKI for TLS tests, made at test time by
// tests/make_test_pki.sh (Debian's openssl): a CA, a server certificate for
// 127.0.0.1 / localhost and a client certificate, all signed by the CA, plus
// a second, untrusted CA.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "lib/io/text_file.h"

namespace meshgauge::testing {

struct TestPki {
  std::string dir;
  std::string ca_crt, server_crt, server_key, client_crt, client_key;
  std::string other_ca_crt;  // a CA that signed nothing of ours.
};

inline std::string ReadFileText(const std::string& path) {
  return ReadTextFile(path, "test file").value_or("");
}

// Returns false when openssl failed (the test should fail then).
inline bool MakeTestPki(TestPki* pki) {
  pki->dir = (std::filesystem::temp_directory_path() /
              ("meshgauge_pki_" + std::to_string(::getpid())))
                 .string();
  std::filesystem::create_directories(pki->dir);
  const std::string d = pki->dir;
  const std::string command = std::string("bash '") + MESHGAUGE_SOURCE_DIR +
                              "/tests/make_test_pki.sh' '" + d + "'";
  if (std::system(command.c_str()) != 0) return false;
  pki->ca_crt = d + "/ca.crt";
  pki->other_ca_crt = d + "/other.crt";
  pki->server_crt = d + "/server.crt";
  pki->server_key = d + "/server.key";
  pki->client_crt = d + "/client.crt";
  pki->client_key = d + "/client.key";
  return true;
}

}  // namespace meshgauge::testing
