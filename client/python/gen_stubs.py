"""Generates the meshgauge.v1 Python stubs from proto/ into a package folder
(meshgauge_client/_proto), with Debian's protoc and grpc_python_plugin, and
makes their imports relative so that no top-level ``meshgauge`` package is
created or needed; copies the clients' service config (retries,
proto/meshgauge/v1/service_config.json) beside them; writes
meshgauge_client/_version.py from the source tree's VERSION (the one
release version of every part).

    python3 gen_stubs.py OUT_DIR [PROTO_DIR]
"""

import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_PROTO = os.path.join(HERE, "..", "..", "proto")
PROTO = "meshgauge/v1/meshgauge.proto"
SERVICE_CONFIG = "meshgauge/v1/service_config.json"


def generate(out_dir: str, proto_dir: str = DEFAULT_PROTO) -> None:
    source = os.path.join(proto_dir, PROTO)
    if not os.path.exists(source):
        raise SystemExit(f"gen_stubs: {source} not found (build from the "
                         "meshgauge source tree)")
    protoc = shutil.which("protoc")
    plugin = shutil.which("grpc_python_plugin")
    if not protoc or not plugin:
        raise SystemExit("gen_stubs: needs protoc and grpc_python_plugin "
                         "(Debian: protobuf-compiler, protobuf-compiler-grpc)")
    os.makedirs(out_dir, exist_ok=True)
    subprocess.run([protoc, f"--proto_path={proto_dir}",
                    f"--python_out={out_dir}", f"--grpc_out={out_dir}",
                    f"--plugin=protoc-gen-grpc={plugin}", source], check=True)
    v1 = os.path.join(out_dir, "meshgauge", "v1")
    grpc_module = os.path.join(v1, "meshgauge_pb2_grpc.py")
    with open(grpc_module) as f:
        text = f.read()
    text = text.replace("from meshgauge.v1 import meshgauge_pb2",
                        "from . import meshgauge_pb2")
    with open(grpc_module, "w") as f:
        f.write(text)
    for package in (out_dir, os.path.join(out_dir, "meshgauge"), v1):
        open(os.path.join(package, "__init__.py"), "a").close()
    shutil.copyfile(os.path.join(proto_dir, SERVICE_CONFIG),
                    os.path.join(out_dir, "service_config.json"))
    with open(os.path.join(os.path.dirname(os.path.abspath(out_dir)),
                           "_version.py"), "w") as f:
        f.write('"""Generated from VERSION by gen_stubs.py."""\n\n'
                f'__version__ = "{release_version(proto_dir)}"\n')


def release_version(proto_dir: str = DEFAULT_PROTO) -> str:
    """The one line of the source tree's VERSION (next to proto/)."""
    with open(os.path.join(proto_dir, "..", "VERSION")) as f:
        return f.readline().strip()


if __name__ == "__main__":
    generate(sys.argv[1], *(sys.argv[2:3] or [DEFAULT_PROTO]))
