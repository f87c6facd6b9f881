"""Python client of the meshgauge gRPC service (numpy in, numpy out).

The stubs come from proto/meshgauge/v1/meshgauge.proto, generated at build
time into build/python (put that folder and this one on PYTHONPATH).
"""

from meshgauge_client.client import MeshGaugeClient, MeshGaugeError, mesh_crc32

__all__ = ["MeshGaugeClient", "MeshGaugeError", "mesh_crc32"]
