/* A small PNG writer in C99 for the examples: 8-bit RGB, each row filtered
 * (PNG's five filters, the one with the smallest sum of magnitudes), one zlib
 * stream of one deflate block with the fixed Huffman codes and greedy LZ77
 * matches. No zlib or libpng needed; the files are larger than zlib's best
 * but a fraction of the raw image. */
#ifndef AACBVH_EXAMPLES_PNG_WRITE_H
#define AACBVH_EXAMPLES_PNG_WRITE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Writes width x height pixels of 3 bytes (R, G, B), rows top to bottom, to
 * `path` as a PNG. Returns NULL, or a message saying what failed. */
const char *png_write_rgb(const char *path, const unsigned char *rgb, uint32_t width, uint32_t height);

/* The CRC-32 of PNG chunks and gzip (polynomial 0xEDB88320, reflected), of
 * `size` bytes continued from `crc`: pass 0 to start. */
uint32_t png_crc32(uint32_t crc, const unsigned char *data, size_t size);

/* The Adler-32 checksum of zlib streams, continued from `adler`: pass 1 to start. */
uint32_t png_adler32(uint32_t adler, const unsigned char *data, size_t size);

#ifdef __cplusplus
}
#endif

#endif /* AACBVH_EXAMPLES_PNG_WRITE_H */
