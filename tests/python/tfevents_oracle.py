#!/usr/bin/python3
"""Independent reader of TensorBoard event files, standard library only (no protobuf module, no code of ours).

Parses the TFRecord framing, verifies both masked CRC32C of every record, decodes the protobuf wire format of
Event / Summary / Value / Image by hand (only the fields bareskin writes; any other field is an error), checks that the
first event is the file version "brain.Event:2" and that every image is a PNG whose IHDR agrees with the Image fields,
and prints one JSON object per line: the file version, then one per summary value with its wall_time, step and tag.

usage: tfevents_oracle.py EVENT_FILE...     exit 0 and the events, or exit 1 and one line naming what is wrong
       tfevents_oracle.py --self-test       checks the CRC against published values and decodes a hand-made record
"""
import json
import struct
import sys


class FormatError(Exception):
    pass


def _crc32c_table():
    table = []
    for i in range(256):
        crc = i
        for _ in range(8):
            crc = (crc >> 1) ^ 0x82F63B78 if crc & 1 else crc >> 1
        table.append(crc)
    return table


CRC_TABLE = _crc32c_table()


def crc32c(data):
    crc = 0xFFFFFFFF
    for b in data:
        crc = CRC_TABLE[(crc ^ b) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


def masked_crc32c(data):
    crc = crc32c(data)
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


def records(raw):
    """The data of each TFRecord in raw, both CRCs verified."""
    pos = 0
    while pos < len(raw):
        if len(raw) - pos < 12:
            raise FormatError(f"truncated record header at byte {pos}")
        header = raw[pos:pos + 8]
        (length,) = struct.unpack("<Q", header)
        (length_crc,) = struct.unpack("<I", raw[pos + 8:pos + 12])
        if length_crc != masked_crc32c(header):
            raise FormatError(f"bad length CRC at byte {pos}")
        start, end = pos + 12, pos + 12 + length
        if end + 4 > len(raw):
            raise FormatError(f"truncated record at byte {pos} ({length} data bytes announced)")
        data = raw[start:end]
        (data_crc,) = struct.unpack("<I", raw[end:end + 4])
        if data_crc != masked_crc32c(data):
            raise FormatError(f"bad data CRC in the record at byte {pos}")
        yield data
        pos = end + 4


def varint(buf, pos):
    value, shift = 0, 0
    while True:
        if pos >= len(buf):
            raise FormatError("truncated varint")
        b = buf[pos]
        pos += 1
        value |= (b & 0x7F) << shift
        if not b & 0x80:
            return value, pos
        shift += 7
        if shift >= 70:
            raise FormatError("varint longer than 10 bytes")


def fields(buf):
    """(field number, wire type, value) of a message: ints for varints, bytes for the others."""
    pos = 0
    while pos < len(buf):
        key, pos = varint(buf, pos)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, pos = varint(buf, pos)
        elif wire == 1:
            value, pos = buf[pos:pos + 8], pos + 8
        elif wire == 5:
            value, pos = buf[pos:pos + 4], pos + 4
        elif wire == 2:
            n, pos = varint(buf, pos)
            value, pos = buf[pos:pos + n], pos + n
        else:
            raise FormatError(f"wire type {wire} (field {number}) is not one we write")
        if pos > len(buf):
            raise FormatError(f"field {number} runs past its message")
        yield number, wire, value


def signed64(v):
    return v - (1 << 64) if v >= 1 << 63 else v


def decode(buf, schema, what):
    """A message as a dict by the schema {number: (name, wire type, converter)}; repeated fields become lists."""
    out = {}
    for number, wire, value in fields(buf):
        if number not in schema or schema[number][1] != wire:
            raise FormatError(f"{what}: unexpected field {number} with wire type {wire}")
        name, _, convert, repeated = schema[number]
        if repeated:
            out.setdefault(name, []).append(convert(value))
        elif name in out:
            raise FormatError(f"{what}: field {name} twice")
        else:
            out[name] = convert(value)
    return out


def utf8(b):
    return b.decode("utf-8")


IMAGE = {1: ("height", 0, int, False), 2: ("width", 0, int, False), 3: ("colorspace", 0, int, False),
         4: ("encoded_image_string", 2, bytes, False)}
VALUE = {1: ("tag", 2, utf8, False), 2: ("simple_value", 5, lambda b: struct.unpack("<f", b)[0], False),
         4: ("image", 2, lambda b: decode(b, IMAGE, "Image"), False)}
SUMMARY = {1: ("value", 2, lambda b: decode(b, VALUE, "Value"), True)}
EVENT = {1: ("wall_time", 1, lambda b: struct.unpack("<d", b)[0], False), 2: ("step", 0, signed64, False),
         3: ("file_version", 2, utf8, False), 5: ("summary", 2, lambda b: decode(b, SUMMARY, "Summary"), False)}

PNG_CHANNELS = {0: 1, 4: 2, 2: 3, 6: 4}


def check_image(image):
    png = image.get("encoded_image_string", b"")
    if png[:8] != b"\x89PNG\r\n\x1a\n" or png[12:16] != b"IHDR":
        raise FormatError("image is not a PNG file")
    width, height, _, colour_type = struct.unpack(">IIBB", png[16:26])
    if (image.get("width"), image.get("height")) != (width, height):
        raise FormatError(f"image fields {image.get('width')}x{image.get('height')} but the PNG is {width}x{height}")
    if colour_type in PNG_CHANNELS and image.get("colorspace") != PNG_CHANNELS[colour_type]:
        raise FormatError(f"colorspace {image.get('colorspace')} but the PNG has colour type {colour_type}")
    return {"height": height, "width": width, "colorspace": image["colorspace"], "png_hex": png.hex()}


def read_events(raw):
    """The events of one file's bytes as the JSON-ready dicts this script prints."""
    out = []
    for index, data in enumerate(records(raw)):
        event = decode(data, EVENT, "Event")
        if "wall_time" not in event:
            raise FormatError(f"event {index} has no wall_time")
        if ("file_version" in event) == ("summary" in event):
            raise FormatError(f"event {index} must hold exactly one of file_version and summary")
        if index == 0 and event.get("file_version") != "brain.Event:2":
            raise FormatError("the first event is not the file version brain.Event:2")
        base = {"wall_time": event["wall_time"], "step": event.get("step", 0)}
        if "file_version" in event:
            out.append(dict(base, file_version=event["file_version"]))
            continue
        for value in event["summary"].get("value", []):
            if not value.get("tag"):
                raise FormatError(f"event {index} has a value without a tag")
            if ("simple_value" in value) == ("image" in value):
                raise FormatError(f"event {index}: a value must hold exactly one of simple_value and image")
            item = dict(base, tag=value["tag"])
            if "image" in value:
                item["image"] = check_image(value["image"])
            else:
                item["simple_value"] = value["simple_value"]
            out.append(item)
    if not out:
        raise FormatError("no events")
    return out


def self_test():
    assert crc32c(b"123456789") == 0xE3069283
    # RFC 3720 (iSCSI) appendix B.4 test vectors.
    assert crc32c(bytes(32)) == 0x8A9136AA
    assert crc32c(b"\xff" * 32) == 0x62A8AB43
    assert crc32c(bytes(range(32))) == 0x46DD794E
    # Event{wall_time: 1.5, step: 300, summary {value {tag: "a" simple_value: 2}}}, assembled by hand from the
    # protobuf encoding rules: key = field << 3 | wire type.
    value = b"\x0a\x01a" + b"\x15" + struct.pack("<f", 2.0)
    event = (b"\x09" + struct.pack("<d", 1.5) + b"\x10\xac\x02" + b"\x2a" + bytes([len(value) + 2]) +
             b"\x0a" + bytes([len(value)]) + value)
    header_event = b"\x09" + struct.pack("<d", 1.0) + b"\x1a\x0dbrain.Event:2"

    def frame(d):
        h = struct.pack("<Q", len(d))
        return h + struct.pack("<I", masked_crc32c(h)) + d + struct.pack("<I", masked_crc32c(d))

    raw = frame(header_event) + frame(event)
    got = read_events(raw)
    assert got == [{"wall_time": 1.0, "step": 0, "file_version": "brain.Event:2"},
                   {"wall_time": 1.5, "step": 300, "tag": "a", "simple_value": 2.0}], got
    for bad in (raw[:-1], raw[:-5] + bytes([raw[-5] ^ 1]) + raw[-4:], raw[:3]):
        try:
            read_events(bad)
        except FormatError:
            continue
        raise AssertionError("a damaged file was accepted")
    print("tfevents_oracle self-test: ok")


def main(argv):
    if argv == ["--self-test"]:
        self_test()
        return 0
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    for path in argv:
        try:
            with open(path, "rb") as f:
                events = read_events(f.read())
        except (FormatError, UnicodeDecodeError) as e:
            print(f"tfevents_oracle: {path}: {e}", file=sys.stderr)
            return 1
        for e in events:
            print(json.dumps(e))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
