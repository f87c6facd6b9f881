#!/usr/bin/env bash
# Makes the stack's secrets in deploy/secrets (not committed): a CA and a
# server certificate for 127.0.0.1 / localhost (tests/make_test_pki.sh), a
# random bearer token for the tenant "stack" (secrets/token) and the
# replicas' tokens file with its SHA-256 (secrets/tokens), and the
# balancer's secrets/server.pem (certificate + key). Idempotent.
# Production: bring your own certificate and tokens instead.
set -euo pipefail
cd "$(dirname "$0")"
mkdir -p secrets
[ -f secrets/ca.crt ] || ../tests/make_test_pki.sh secrets
if [ ! -f secrets/token ]; then
  head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' >secrets/token
fi
echo "stack $(tr -d '\n' <secrets/token | sha256sum | cut -d' ' -f1)" >secrets/tokens
# HAProxy reads the certificate and its key from one file.
cat secrets/server.crt secrets/server.key >secrets/server.pem
chmod 0644 secrets/*
