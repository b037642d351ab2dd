#!/usr/bin/python3
"""Small gRPC probe for tests/deploy_test.sh (Debian's python3-grpcio, no generated code).

Messages are encoded by hand (a few protobuf fields), so the probe needs neither protoc nor the
shrm.v1 stubs. Every command prints one line, the gRPC status code name (or the health status),
and exits 0 when the call itself could be made.

  grpc_probe.py health TARGET SERVICE         -> SERVING | NOT_SERVING | SERVICE_UNKNOWN | <code>
  grpc_probe.py hasblob TARGET [PAD_BYTES]    -> status code of HasBlob (PAD_BYTES: request size)
  grpc_probe.py upload TARGET DECLARED_MIB SENT_MIB
                                              -> status code of UploadBlob declaring DECLARED_MIB
                                                 and streaming SENT_MIB in 1 MiB chunks
"""
import sys

import grpc

TIMEOUT_S = 30


def varint(n):
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def field_bytes(number, payload):
    return varint((number << 3) | 2) + varint(len(payload)) + payload


def field_varint(number, value):
    return varint(number << 3) + varint(value)


def code_name(err):
    """The status code's name; the message goes to stderr (who answered: nginx or shrmd)."""
    code = err.code()
    print("grpc_probe: %s" % err.details(), file=sys.stderr)
    return code.name if code is not None else "UNKNOWN"


def health(channel, service):
    call = channel.unary_unary("/grpc.health.v1.Health/Check")
    try:
        resp = call(field_bytes(1, service.encode()), timeout=TIMEOUT_S)
    except grpc.RpcError as err:
        if err.code() == grpc.StatusCode.NOT_FOUND:
            return "SERVICE_UNKNOWN"
        return code_name(err)
    # HealthCheckResponse { ServingStatus status = 1; }: UNKNOWN 0, SERVING 1, NOT_SERVING 2.
    status = 0
    if len(resp) >= 2 and resp[0] == 0x08:
        status = resp[1]
    return {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}.get(status, "?")


def hasblob(channel, pad_bytes):
    call = channel.unary_unary("/shrm.v1.Shrm/HasBlob")
    # A well-formed hash, optionally padded by an unknown field (number 15) to make the request
    # body as large as wanted: servers skip unknown fields, a proxy counts the bytes.
    req = field_bytes(1, b"0" * 64)
    if pad_bytes > len(req):
        req += field_bytes(15, b"x" * (pad_bytes - len(req)))
    try:
        call(req, timeout=TIMEOUT_S)
        return "OK"
    except grpc.RpcError as err:
        return code_name(err)


def upload(channel, declared_mib, sent_mib):
    call = channel.stream_unary("/shrm.v1.Shrm/UploadBlob")
    chunk = b"\0" * (1 << 20)

    def chunks():
        first = field_bytes(1, b"0" * 64) + field_varint(2, declared_mib << 20)
        for i in range(sent_mib):
            yield (first if i == 0 else b"") + field_bytes(3, chunk)

    try:
        call(chunks(), timeout=TIMEOUT_S)
        return "OK"
    except grpc.RpcError as err:
        return code_name(err)


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    cmd, target = argv[1], argv[2]
    with grpc.insecure_channel(target) as channel:
        if cmd == "health" and len(argv) == 4:
            print(health(channel, argv[3]))
        elif cmd == "hasblob" and len(argv) in (3, 4):
            print(hasblob(channel, int(argv[3]) if len(argv) == 4 else 0))
        elif cmd == "upload" and len(argv) == 5:
            print(upload(channel, int(argv[3]), int(argv[4])))
        else:
            print(__doc__, file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
