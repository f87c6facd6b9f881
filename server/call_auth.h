// Authentication of every call from its metadata, before any of its
// message is read.
//
// gRPC's synchronous server reads a unary call's whole request before the
// handler runs, so a handler's token check comes after the memory is
// committed (an anonymous 170 MiB UpdatePositions held 170 MiB). These
// credentials attach an auth-metadata processor to the listening port: the
// transport asks it about each call's initial metadata and fails a call
// without a valid token with UNAUTHENTICATED before reading its messages,
// so an anonymous call costs O(1) memory (at most HTTP/2's flow-control
// window of unread bytes until the stream is reset).
//
// The standard health service (grpc.health.v1.Health) stays open: load
// balancers probe it without a token and it reveals nothing but
// SERVING/NOT_SERVING. The streamed upload (CreateSession) is let through to
// its handler, which authenticates before it reads any message (gRPC does
// not read a stream ahead of the handler) and then drains the stream, so
// the client sees UNAUTHENTICATED even through a balancer (refused here, a
// client still sending met a reset stream, CANCELLED, behind HAProxy).
// Everything else, reflection included, needs a token when the server has
// tokens. The handlers still authenticate (to learn the tenant and to
// refuse a token revoked in between).
#pragma once

#include <grpcpp/security/server_credentials.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/auth.h"

namespace meshgauge::server {

// TLS material for CallAuthCredentials; all PEM text. Empty cert_chain:
// plaintext.
struct TlsMaterial {
  std::string cert_chain;
  std::string private_key;
  std::string client_ca;  // Non-empty: client certificates are required.
};

// Credentials for ServerBuilder::AddListeningPort. `auth` must outlive the
// server; in open mode (no tokens) no processor is attached and every call
// is let through as before.
std::shared_ptr<grpc::ServerCredentials> CallAuthCredentials(
    const TlsMaterial& tls, const Authenticator* auth);

}  // namespace meshgauge::server
