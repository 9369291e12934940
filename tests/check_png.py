#!/usr/bin/env python3
"""Checks a PNG written by examples/render (examples/png_write.c) with nothing
but the standard library: the signature; IHDR (size, 8-bit RGB, no interlace);
every chunk's CRC-32; IDAT's zlib stream, inflated by Python's zlib, its
Adler-32 and its length; every row's filter undone; and that the picture is a
picture: not one colour, with a fair share of surface pixels (render's
surfaces are grey, r >= b; its sky is blue) and of those, a fair share lit
(brighter than render's ambient-only shade).

    check_png.py FILE WIDTH HEIGHT [--min-surface F] [--min-lit F]

Before judging FILE, it checks that the checks can fail: a copy with one
IDAT byte flipped, a truncated copy and a one-colour image must be refused.
Exit status 0 when FILE passes, 1 with the reasons otherwise.
"""
import argparse
import struct
import sys
import zlib

SIGNATURE = b"\x89PNG\r\n\x1a\n"
# render's ambient-only surface is about 88 in each channel; lit ones are brighter.
LIT_LEVEL = 100


def chunks(data):
    """(type, body, crc_ok) for each chunk; raises ValueError when truncated."""
    pos = len(SIGNATURE)
    while pos < len(data):
        if pos + 12 > len(data):
            raise ValueError("truncated chunk header at byte %d" % pos)
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        end = pos + 8 + length
        if end + 4 > len(data):
            raise ValueError("chunk %r runs past the end of the file" % kind)
        body = data[pos + 8:end]
        (crc,) = struct.unpack(">I", data[end:end + 4])
        yield kind, body, crc == zlib.crc32(kind + body) & 0xFFFFFFFF
        pos = end + 4


def paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def unfilter(raw, width, height):
    """The RGB rows of a decompressed IDAT stream (PNG spec, section 9)."""
    stride = 3 * width
    rows, above = [], bytearray(stride)
    for y in range(height):
        start = y * (stride + 1)
        kind, line = raw[start], bytearray(raw[start + 1:start + 1 + stride])
        if kind > 4:
            raise ValueError("row %d: unknown filter type %d" % (y, kind))
        for i in range(stride):
            a = line[i - 3] if i >= 3 else 0
            b = above[i]
            c = above[i - 3] if i >= 3 else 0
            pred = (0, a, b, (a + b) // 2, paeth(a, b, c))[kind]
            line[i] = (line[i] + pred) & 0xFF
        rows.append(line)
        above = line
    return rows


def check(data, width, height, min_surface, min_lit):
    """A list of what is wrong with the PNG `data` (empty when nothing is)."""
    if not data.startswith(SIGNATURE):
        return ["no PNG signature"]
    try:
        found = list(chunks(data))
    except ValueError as e:
        return [str(e)]
    problems = ["chunk %s: CRC mismatch" % k.decode("latin-1") for k, _, ok in found if not ok]
    kinds = [k for k, _, _ in found]
    if not kinds or kinds[0] != b"IHDR" or kinds[-1] != b"IEND" or b"IDAT" not in kinds:
        return problems + ["chunks are %r, not IHDR ... IDAT ... IEND" % kinds]
    ihdr = found[0][1]
    if len(ihdr) != 13:
        return problems + ["IHDR has %d bytes, not 13" % len(ihdr)]
    w, h, depth, colour, method, filtering, interlace = struct.unpack(">IIBBBBB", ihdr)
    if (w, h) != (width, height):
        problems.append("IHDR says %dx%d, expected %dx%d" % (w, h, width, height))
    if (depth, colour, method, filtering, interlace) != (8, 2, 0, 0, 0):
        problems.append("IHDR is not 8-bit RGB, deflate, adaptive filters, no interlace")
    if problems:
        return problems

    stream = b"".join(body for k, body, _ in found if k == b"IDAT")
    inflater = zlib.decompressobj()
    try:
        raw = inflater.decompress(stream)  # zlib checks the Adler-32 itself
    except zlib.error as e:
        return ["IDAT does not inflate: %s" % e]
    if not inflater.eof or inflater.unused_data:
        return ["IDAT's zlib stream is unfinished or followed by extra bytes"]
    (adler,) = struct.unpack(">I", stream[-4:])
    if adler != zlib.adler32(raw) & 0xFFFFFFFF:
        problems.append("Adler-32 mismatch")
    if len(raw) != height * (3 * width + 1):
        return problems + ["IDAT holds %d bytes, expected %d" % (len(raw), height * (3 * width + 1))]
    try:
        rows = unfilter(raw, width, height)
    except ValueError as e:
        return problems + [str(e)]

    pixels = [tuple(row[i:i + 3]) for row in rows for i in range(0, len(row), 3)]
    surface = [p for p in pixels if p[0] >= p[2]]
    lit = [p for p in surface if min(p) > LIT_LEVEL]
    if len(set(pixels)) < 16:
        problems.append("blank: only %d distinct colours" % len(set(pixels)))
    if len(surface) < min_surface * len(pixels):
        problems.append("%d of %d pixels show a surface, fewer than %.0f%%"
                        % (len(surface), len(pixels), 100 * min_surface))
    elif len(lit) < min_lit * len(surface):
        problems.append("%d of %d surface pixels lit, fewer than %.0f%%"
                        % (len(lit), len(surface), 100 * min_lit))
    return problems


def png_bytes(width, height, rgb_rows):
    """A PNG of unfiltered rows, for the one-colour case of the self-test."""
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    raw = b"".join(b"\x00" + bytes(r) for r in rgb_rows)
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return SIGNATURE + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("file")
    parser.add_argument("width", type=int)
    parser.add_argument("height", type=int)
    parser.add_argument("--min-surface", type=float, default=0.05)
    parser.add_argument("--min-lit", type=float, default=0.5)
    args = parser.parse_args()
    with open(args.file, "rb") as f:
        data = f.read()
    limits = (args.width, args.height, args.min_surface, args.min_lit)

    # The checks must be able to fail.
    idat = data.find(b"IDAT")
    flipped = bytearray(data)
    flipped[idat + 8] ^= 0x10
    grey = png_bytes(args.width, args.height, [[128] * (3 * args.width)] * args.height)
    for name, bad in (("a flipped IDAT byte", bytes(flipped)), ("a truncated file", data[:len(data) // 2]),
                      ("a one-colour image", grey)):
        if idat < 0 or not check(bad, *limits):
            print("check_png: the check accepts %s" % name)
            return 1

    problems = check(data, *limits)
    for p in problems:
        print("%s: %s" % (args.file, p))
    if not problems:
        print("%s: a valid %dx%d PNG, not blank" % (args.file, args.width, args.height))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
