#!/usr/bin/env bash
# The stack's secrets in $MESHGAUGE_SECRETS_DIR (default deploy/secrets, not
# committed):
#   ca.key, ca.crt            the stack's CA (MESHGAUGE_CA_DAYS, default 3650)
#   server.key, server.crt    the balancer's certificate, signed by the CA
#                             (MESHGAUGE_CERT_DAYS, default 365), for the
#                             names of MESHGAUGE_CERT_NAMES: a comma-separated
#                             list of DNS names and IP addresses (default
#                             "127.0.0.1,localhost"; the clients' --server
#                             host must be one of them)
#   server.pem                certificate and key in one file, for HAProxy
#   token                     the bearer token of the tenant "stack"
#   balancer/server.pem       the copy the balancer container reads (owned by
#                             its user, uid 10080)
#   replicas/tokens           the replicas' tokens file: the SHA-256 of each
#                             valid token (no secret; mode 0644)
# Keys, the token and the PEMs are mode 0600. The containers mount the
# directories balancer/ and replicas/, so a file replaced there is seen.
#   make-secrets.sh           make what is missing; renew a certificate (the
#                             CA's: and the server's) when under 30 days
#                             remain, and the server's when its names are
#                             not MESHGAUGE_CERT_NAMES
#   make-secrets.sh rotate    a new server key and certificate (same CA: the
#                             clients' trust holds) and a new token in
#                             token.next; the tokens file lists both tokens
#   make-secrets.sh publish   token.next becomes token (the old one is kept
#                             as token.previous, still valid)
#   make-secrets.sh finish    the tokens file lists the current token alone
# (deploy/stack.sh rotate-secrets runs these and reloads the stack between.)
# Production: bring your own certificate and tokens instead.
set -euo pipefail
cd "$(dirname "$0")"
SECRETS=${MESHGAUGE_SECRETS_DIR:-secrets}
umask 077
mkdir -p "$SECRETS/balancer" "$SECRETS/replicas"
chmod 0755 "$SECRETS" "$SECRETS/balancer" "$SECRETS/replicas"
cd "$SECRETS"

# subjectAltName of MESHGAUGE_CERT_NAMES: IP:... for addresses, DNS:... else.
alt_names() {
  local n out=() names
  IFS=, read -ra names <<<"${MESHGAUGE_CERT_NAMES:-127.0.0.1,localhost}"
  for n in "${names[@]}"; do
    n=$(tr -d ' ' <<<"$n")
    [ -n "$n" ] || continue
    if [[ "$n" =~ ^[0-9.]+$ || "$n" == *:* ]]; then out+=("IP:$n"); else out+=("DNS:$n"); fi
  done
  [ ${#out[@]} -gt 0 ] || { echo "make-secrets: MESHGAUGE_CERT_NAMES names nothing" >&2; exit 2; }
  (IFS=,; echo "${out[*]}")
}

# The names server.crt was made for, in alt_names' form: server.names,
# written with it (or, for a certificate of an earlier release, its
# subjectAltName as OpenSSL prints it: "IP Address:1.2.3.4, DNS:x").
cert_names() {
  cat server.names 2>/dev/null ||
    openssl x509 -noout -ext subjectAltName -in server.crt 2>/dev/null | sed 1d |
      tr -d ' ' | sed 's/IPAddress:/IP:/g'
}
BALANCER_UID=10080
key=(-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes)

new_ca() {
  openssl req -x509 "${key[@]}" -keyout ca.key -out ca.crt \
    -days "${MESHGAUGE_CA_DAYS:-3650}" -subj /CN=meshgauge-stack-ca 2>/dev/null
  chmod 0644 ca.crt
}

new_server_certificate() {
  openssl req "${key[@]}" -keyout server.key -out server.csr \
    -subj /CN=meshgauge-balancer 2>/dev/null
  alt_names >server.names
  chmod 0644 server.names
  printf 'subjectAltName=%s\n' "$(cat server.names)" >server.ext
  openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial \
    -days "${MESHGAUGE_CERT_DAYS:-365}" -extfile server.ext -out server.crt \
    2>/dev/null
  chmod 0644 server.crt
  rm -f server.csr server.ext
  cat server.crt server.key >server.pem
  # The balancer's copy, replaced in one rename (the old one serves until
  # the balancer reloads).
  rm -f balancer/.server.pem.new  # a leftover of an interrupted run.
  cp server.pem balancer/.server.pem.new
  if [ "$(id -u)" -eq 0 ]; then
    chown "$BALANCER_UID:$BALANCER_UID" balancer/.server.pem.new
  else  # the operator may not chown; a container may.
    docker run --rm --user 0 --network none -v "$PWD/balancer:/s" \
      --entrypoint chown meshgauge/bookworm-base:latest \
      "$BALANCER_UID:$BALANCER_UID" /s/.server.pem.new
  fi
  mv -f balancer/.server.pem.new balancer/server.pem
}

lasts_a_month() {  # CERTIFICATE
  openssl x509 -checkend $((30 * 86400)) -noout -in "$1" >/dev/null 2>&1
}

new_token() {  # FILE
  head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' >"$1"
}

# The tokens file: the current token and, during a rotation, the previous.
write_tokens() {  # TOKEN_FILES...
  local f
  for f in "$@"; do
    echo "stack $(tr -d '\n' <"$f" | sha256sum | cut -d' ' -f1)"
  done >replicas/.tokens.new
  chmod 0644 replicas/.tokens.new
  mv -f replicas/.tokens.new replicas/tokens
}

case "${1:-}" in
  "")
    renew=0
    if [ ! -f ca.key ] || ! lasts_a_month ca.crt; then new_ca; renew=1; fi
    if [ "$renew" = 1 ] || [ ! -f balancer/server.pem ] ||
       ! lasts_a_month server.crt || [ "$(cert_names)" != "$(alt_names)" ]; then
      new_server_certificate
    fi
    [ -f token ] || new_token token
    [ -f replicas/tokens ] || write_tokens token
    ;;
  rotate)
    if [ -f token.next ] || [ -f token.previous ]; then
      echo "make-secrets: a rotation is under way; finish it first (deploy/stack.sh rotate-secrets --finish)" >&2
      exit 1
    fi
    new_server_certificate
    new_token token.next
    write_tokens token token.next
    ;;
  publish)
    [ -f token.next ] || { echo "make-secrets: no token.next to publish" >&2; exit 1; }
    mv -f token token.previous
    mv -f token.next token
    ;;
  finish)
    write_tokens token
    rm -f token.previous token.next
    ;;
  *)
    echo "usage: make-secrets.sh [rotate | publish | finish]" >&2
    exit 2
    ;;
esac
# Files written over keep their mode, and earlier releases made them 0644.
for f in ca.key server.key server.pem token token.next token.previous; do
  [ ! -f "$f" ] || chmod 0600 "$f"
done
