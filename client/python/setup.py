"""Build hook: the stubs (and _version.py) are generated from ../../proto
and ../../VERSION at build time."""

import os
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


setup(version=gen_stubs.release_version(),
      cmdclass={"build_py": BuildWithStubs})
