"""scripts/fetch_npm_lock.py, offline: lock files whose packages resolve to
local tarballs (file:// addresses)."""
import base64
import hashlib
import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                      "scripts", "fetch_npm_lock.py")


def tarball(files):
    """A .tgz of {path in the archive: bytes}."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for path, data in files.items():
            info = tarfile.TarInfo(path)
            info.size = len(data)
            info.mode = 0o755 if path.endswith("/bin/tool") else 0o644
            tar.addfile(info, io.BytesIO(data))
    return buf.getvalue()


def integrity(data):
    return "sha512-" + base64.b64encode(hashlib.sha512(data).digest()).decode()


class FetchNpmLockTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.web = self.dir.name

    def tearDown(self):
        self.dir.cleanup()

    def package(self, name, files, **meta):
        data = tarball(files)
        path = os.path.join(self.web, name.replace("/", "_") + ".tgz")
        with open(path, "wb") as f:
            f.write(data)
        entry = {"version": "1.0.0", "resolved": "file://" + path,
                 "integrity": integrity(data)}
        entry.update(meta)
        return "node_modules/" + name, entry

    def run_script(self, packages):
        lock = {"lockfileVersion": 3,
                "packages": {"": {"name": "t"}, **dict(packages)}}
        with open(os.path.join(self.web, "package-lock.json"), "w") as f:
            json.dump(lock, f)
        return subprocess.run([sys.executable, SCRIPT, self.web],
                              capture_output=True, text=True, timeout=60)

    def test_packages_are_unpacked_with_their_modes(self):
        r = self.run_script([
            self.package("lib", {"package/index.js": b"x=1"}),
            self.package("@scope/tool", {"package/bin/tool": b"#!/bin/sh\n"})])
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(self.web, "node_modules/lib/index.js")) as f:
            self.assertEqual(f.read(), "x=1")
        self.assertTrue(os.access(
            os.path.join(self.web, "node_modules/@scope/tool/bin/tool"),
            os.X_OK))

    def test_a_tarball_that_does_not_match_its_integrity_is_refused(self):
        key, entry = self.package("lib", {"package/index.js": b"x=1"})
        entry["integrity"] = integrity(b"another file")
        r = self.run_script([(key, entry)])
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("does not match its integrity", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.web, key)))

    def test_a_path_leaving_the_package_folder_is_refused(self):
        r = self.run_script([self.package(
            "lib", {"package/../../../escaped.js": b"x=1"})])
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("leaves its folder", r.stderr)
        self.assertFalse(os.path.exists(
            os.path.join(self.web, "..", "escaped.js")))
        self.assertFalse(os.path.exists(
            os.path.join(self.web, "node_modules", "lib")))

    def test_an_optional_package_of_another_platform_is_skipped(self):
        r = self.run_script([self.package(
            "@esbuild/aix-ppc64", {"package/bin/tool": b""},
            optional=True, os=["aix"], cpu=["ppc64"])])
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertFalse(os.path.exists(
            os.path.join(self.web, "node_modules/@esbuild/aix-ppc64")))


if __name__ == "__main__":
    unittest.main()
