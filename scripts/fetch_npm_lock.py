#!/usr/bin/python3
"""Installs the packages web/package-lock.json pins, without node or npm.

What `npm ci` does for a lock file without install scripts: each package's
tarball is downloaded from its `resolved` address, or where the lock omits
it, from the registry's address for its name and version (the registry is
$npm_config_registry, as for npm, or registry.npmjs.org), its `integrity` hash (Subresource Integrity, sha512) checked, and its files
unpacked into node_modules/NAME. Optional packages for another platform
(esbuild ships one native binary package per os/cpu) are skipped, as npm
skips them. A package whose hash does not match, or a tarball with a path
outside its folder, fails the run and installs nothing of that package.

Why not npm: Debian's npm package pulls in about 420 packages (a fresh
Debian 12 machine spent most of its apt time on them) to fetch the three
packages the report page's bundle needs; esbuild runs as its own binary.

    fetch_npm_lock.py WEB_DIR
"""
import base64
import hashlib
import io
import json
import os
import platform
import shutil
import sys
import tarfile
import urllib.request

NODE_OS = {"Linux": "linux", "Darwin": "darwin"}
NODE_CPU = {"x86_64": "x64", "aarch64": "arm64", "arm64": "arm64"}


def wanted(meta):
    """False for an optional package built for another os or cpu."""
    os_name = NODE_OS.get(platform.system(), platform.system().lower())
    cpu = NODE_CPU.get(platform.machine(), platform.machine())
    return (os_name in meta.get("os", [os_name])
            and cpu in meta.get("cpu", [cpu]))


def verified(data, integrity, name):
    algorithm, _, digest = integrity.partition("-")
    if algorithm not in ("sha512", "sha384", "sha256"):
        raise SystemExit(f"fetch_npm_lock: {name}: unsupported integrity "
                         f"{algorithm!r}")
    actual = base64.b64encode(hashlib.new(algorithm, data).digest()).decode()
    if actual != digest:
        raise SystemExit(f"fetch_npm_lock: {name}: the download does not "
                         f"match its integrity {integrity}")
    return data


def unpack(data, target, name):
    """The tarball's package/ folder into target (npm's layout)."""
    tmp = os.path.abspath(target + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        for member in tar.getmembers():
            path = member.name.split("/", 1)[1] if "/" in member.name else ""
            if not path or not (member.isfile() or member.isdir()):
                continue
            dest = os.path.normpath(os.path.join(tmp, path))
            if not dest.startswith(tmp + os.sep):
                raise SystemExit(f"fetch_npm_lock: {name}: {member.name} "
                                 "leaves its folder")
            if member.isdir():
                os.makedirs(dest, exist_ok=True)
                continue
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            with tar.extractfile(member) as src, open(dest, "wb") as out:
                shutil.copyfileobj(src, out)
            os.chmod(dest, 0o755 if member.mode & 0o111 else 0o644)
    shutil.rmtree(target, ignore_errors=True)
    os.replace(tmp, target)


def tarball_url(name, meta):
    if "resolved" in meta:
        return meta["resolved"]
    registry = os.environ.get("npm_config_registry",
                              "https://registry.npmjs.org/").rstrip("/")
    base = name.rsplit("/", 1)[-1]
    return f"{registry}/{name}/-/{base}-{meta['version']}.tgz"


def main():
    web = sys.argv[1]
    with open(os.path.join(web, "package-lock.json")) as f:
        lock = json.load(f)
    for key, meta in lock["packages"].items():
        if not key.startswith("node_modules/"):
            continue
        if meta.get("optional") and not wanted(meta):
            continue
        name = key[len("node_modules/"):]
        with urllib.request.urlopen(tarball_url(name, meta),
                                    timeout=120) as r:
            data = verified(r.read(), meta["integrity"], name)
        unpack(data, os.path.join(web, key), name)
        print(f"fetch_npm_lock: {name} {meta['version']}")


if __name__ == "__main__":
    main()
