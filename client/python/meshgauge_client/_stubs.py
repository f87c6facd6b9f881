"""The generated meshgauge.v1 stubs (untyped protobuf code, typed as Any)."""

from typing import Any

from meshgauge_client._proto.meshgauge.v1 import meshgauge_pb2 as _pb
from meshgauge_client._proto.meshgauge.v1 import meshgauge_pb2_grpc as _pb_grpc

pb: Any = _pb
pb_grpc: Any = _pb_grpc
