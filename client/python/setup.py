"""Build hook: the stubs (and _version.py) are generated from ../../proto
and ../../VERSION at build time."""

import os
import shutil
import sys

from setuptools import setup
from setuptools.command.build_py import build_py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen_stubs  # noqa: E402


class BuildWithStubs(build_py):
    def run(self) -> None:
        super().run()
        gen_stubs.generate(os.path.join(self.build_lib, "meshgauge_client",
                                        "_proto"))
        # The report page's scripts (Session.report), when
        # scripts/install_web_deps.sh has bundled them.
        web = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                           "..", "web")
        out = os.path.join(self.build_lib, "meshgauge_client", "web")
        for name in ("vendor/three.bundle.min.js", "vendor/three.LICENSE",
                     "report_viewer.js", "report_viewer.html"):
            if os.path.exists(os.path.join(web, name)):
                os.makedirs(out, exist_ok=True)
                shutil.copy(os.path.join(web, name), out)


setup(version=gen_stubs.release_version(),
      cmdclass={"build_py": BuildWithStubs})
