#!/usr/bin/env bash
# A throw-away PKI for TLS tests (Debian's openssl, EC P-256, 2 days):
# DIR/ca.crt signs server.crt (127.0.0.1, localhost) and client.crt;
# DIR/other.crt is a CA that signed nothing of ours.
#   make_test_pki.sh DIR
set -euo pipefail
mkdir -p "$1"
cd "$1"
key=(-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes)
openssl req -x509 "${key[@]}" -keyout ca.key -out ca.crt -days 2 \
  -subj /CN=meshgauge-test-ca 2>/dev/null
openssl req -x509 "${key[@]}" -keyout other.key -out other.crt -days 2 \
  -subj /CN=other-ca 2>/dev/null
printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\n' >server.ext
for who in server client; do
  openssl req "${key[@]}" -keyout "$who.key" -out "$who.csr" \
    -subj "/CN=meshgauge-test-$who" 2>/dev/null
  ext=()
  [ "$who" = server ] && ext=(-extfile server.ext)
  openssl x509 -req -in "$who.csr" -CA ca.crt -CAkey ca.key -CAcreateserial \
    -out "$who.crt" -days 2 "${ext[@]}" 2>/dev/null
done
