/* PNG writer (png_write.h). The format: the 8-byte signature, then chunks of
 * (length, type, data, CRC-32 of type and data): IHDR, one IDAT holding a zlib
 * stream of the filtered rows, IEND (PNG spec, W3C 2003; RFC 1950, 1951). */
#include "png_write.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- checksums ---- */

uint32_t png_crc32(uint32_t crc, const unsigned char *data, size_t size) {
    uint32_t table[256], n, c;
    size_t i;
    int k;
    /* Rebuilt per call (a few microseconds) rather than kept in shared state. */
    for (n = 0; n < 256; ++n) {
        for (c = n, k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[n] = c;
    }
    crc = ~crc;
    for (i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xFF] ^ (crc >> 8);
    return ~crc;
}

uint32_t png_adler32(uint32_t adler, const unsigned char *data, size_t size) {
    uint32_t a = adler & 0xFFFF, b = adler >> 16;
    while (size > 0) {
        /* 5552 bytes is the most that cannot overflow b before the modulo (RFC 1950). */
        size_t n = size < 5552 ? size : 5552, i;
        for (i = 0; i < n; ++i) {
            a += data[i];
            b += a;
        }
        a %= 65521;
        b %= 65521;
        data += n;
        size -= n;
    }
    return (b << 16) | a;
}

/* ---- deflate: one block, fixed Huffman codes (RFC 1951, 3.2.6) ---- */

typedef struct bit_writer {
    unsigned char *out;
    size_t size;     /* bytes complete */
    uint32_t bits;   /* pending bits, least significant first */
    int count;       /* how many */
} bit_writer;

static void put_bits(bit_writer *w, uint32_t value, int count) {
    w->bits |= value << w->count;
    w->count += count;
    while (w->count >= 8) {
        w->out[w->size++] = (unsigned char)w->bits;
        w->bits >>= 8;
        w->count -= 8;
    }
}

/* Huffman codes go most significant bit first, the rest least significant first. */
static void put_code(bit_writer *w, uint32_t code, int length) {
    uint32_t reversed = 0;
    int i;
    for (i = 0; i < length; ++i) reversed |= ((code >> i) & 1u) << (length - 1 - i);
    put_bits(w, reversed, length);
}

/* Literal/length symbol 0..287 in the fixed code. */
static void put_symbol(bit_writer *w, int symbol) {
    if (symbol < 144) put_code(w, 0x30u + (uint32_t)symbol, 8);
    else if (symbol < 256) put_code(w, 0x190u + (uint32_t)(symbol - 144), 9);
    else if (symbol < 280) put_code(w, (uint32_t)(symbol - 256), 7);
    else put_code(w, 0xC0u + (uint32_t)(symbol - 280), 8);
}

static const uint16_t kLengthBase[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                         31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
static const uint8_t kLengthExtra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                         2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
static const uint16_t kDistanceBase[30] = {1,   2,   3,   4,   5,   7,    9,    13,   17,   25,
                                           33,  49,  65,  97,  129, 193,  257,  385,  513,  769,
                                           1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
static const uint8_t kDistanceExtra[30] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                           6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

static void put_match(bit_writer *w, int length, int distance) {
    int l = 28, d = 29;
    while (kLengthBase[l] > length) --l;
    while (kDistanceBase[d] > distance) --d;
    put_symbol(w, 257 + l);
    put_bits(w, (uint32_t)(length - kLengthBase[l]), kLengthExtra[l]);
    put_code(w, (uint32_t)d, 5); /* distance codes are all 5 bits long */
    put_bits(w, (uint32_t)(distance - kDistanceBase[d]), kDistanceExtra[d]);
}

enum { kWindow = 32768, kMinMatch = 3, kMaxMatch = 258, kHashBits = 15, kMaxChain = 48 };

static uint32_t hash3(const unsigned char *p) {
    return ((uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2]) * 2654435761u >> (32 - kHashBits);
}

/* Compresses in[0 .. size) into one final fixed-code block at w. Greedy LZ77:
 * at each position the longest match among the last kMaxChain positions with
 * the same 3-byte hash, else a literal. Returns 0 when memory runs out. */
static int deflate_fixed(bit_writer *w, const unsigned char *in, size_t size) {
    long *head = (long *)malloc(((size_t)1 << kHashBits) * sizeof(long));
    long *prev = (long *)malloc((size_t)kWindow * sizeof(long));
    size_t pos = 0, i;
    if (!head || !prev) {
        free(head);
        free(prev);
        return 0;
    }
    for (i = 0; i < ((size_t)1 << kHashBits); ++i) head[i] = -1;
    put_bits(w, 1, 1); /* BFINAL */
    put_bits(w, 1, 2); /* BTYPE 01: fixed codes */
    while (pos < size) {
        int best = 0, best_distance = 0;
        if (size - pos >= kMinMatch) {
            uint32_t h = hash3(in + pos);
            long candidate = head[h];
            int chain = kMaxChain;
            size_t limit = size - pos < kMaxMatch ? size - pos : kMaxMatch;
            while (candidate >= 0 && pos - (size_t)candidate <= kWindow && chain-- > 0) {
                const unsigned char *a = in + candidate, *b = in + pos;
                size_t n = 0;
                while (n < limit && a[n] == b[n]) ++n;
                if ((int)n > best) {
                    best = (int)n;
                    best_distance = (int)(pos - (size_t)candidate);
                    if (n == limit) break;
                }
                candidate = prev[candidate % kWindow];
            }
        }
        if (best < kMinMatch) best = 1;
        if (best == 1) put_symbol(w, in[pos]);
        else put_match(w, best, best_distance);
        /* Every position covered goes into the hash chains. */
        for (i = 0; i < (size_t)best; ++i, ++pos) {
            if (size - pos >= kMinMatch) {
                uint32_t h = hash3(in + pos);
                prev[pos % kWindow] = head[h];
                head[h] = (long)pos;
            }
        }
    }
    put_symbol(w, 256); /* end of block */
    if (w->count > 0) put_bits(w, 0, 8 - w->count);
    free(head);
    free(prev);
    return 1;
}

/* ---- PNG filters (PNG spec, 9) ---- */

static int paeth(int a, int b, int c) {
    int p = a + b - c, pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
    if (pa <= pb && pa <= pc) return a;
    return pb <= pc ? b : c;
}

/* Writes the filter byte and filtered row to `out`: the filter whose output,
 * read as signed bytes, has the smallest sum of magnitudes (the spec's advice),
 * which keeps smooth gradients near zero and compressible. */
static void filter_row(const unsigned char *row, const unsigned char *above, size_t bytes, unsigned char *scratch,
                       unsigned char *out) {
    const size_t bpp = 3;
    unsigned long best_sum = (unsigned long)-1;
    int best = 0, f;
    size_t i;
    for (f = 0; f < 5; ++f) {
        unsigned char *dst = scratch + (size_t)f * bytes;
        unsigned long sum = 0;
        for (i = 0; i < bytes; ++i) {
            int a = i >= bpp ? row[i - bpp] : 0, b = above ? above[i] : 0;
            int c = above && i >= bpp ? above[i - bpp] : 0;
            int predicted = f == 0 ? 0 : f == 1 ? a : f == 2 ? b : f == 3 ? (a + b) / 2 : paeth(a, b, c);
            dst[i] = (unsigned char)(row[i] - predicted);
            sum += dst[i] < 128 ? dst[i] : 256u - dst[i];
        }
        if (sum < best_sum) {
            best_sum = sum;
            best = f;
        }
    }
    out[0] = (unsigned char)best;
    memcpy(out + 1, scratch + (size_t)best * bytes, bytes);
}

/* ---- the file ---- */

static void put_u32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* One chunk: `data` is preceded by 8 free bytes (length and type) and followed
 * by 4 (the CRC), so the chunk goes out in one write. */
static int write_chunk(FILE *f, const char type[4], unsigned char *data, size_t size) {
    put_u32(data - 8, (uint32_t)size);
    memcpy(data - 4, type, 4);
    put_u32(data + size, png_crc32(0, data - 4, size + 4));
    return fwrite(data - 8, 1, size + 12, f) == size + 12;
}

const char *png_write_rgb(const char *path, const unsigned char *rgb, uint32_t width, uint32_t height) {
    static const unsigned char signature[8] = {137, 'P', 'N', 'G', '\r', '\n', 26, '\n'};
    unsigned char ihdr[8 + 13 + 4], iend[8 + 4];
    const size_t row_bytes = (size_t)width * 3, raw_size = (row_bytes + 1) * height;
    unsigned char *raw = NULL, *scratch = NULL, *chunk = NULL;
    bit_writer w = {NULL, 0, 0, 0};
    const char *error = NULL;
    size_t y;
    uint32_t adler;
    FILE *f;

    /* The spec's limit is 2^31 - 1 pixels a side; one IDAT chunk must also stay under 2^31 bytes. */
    if (width == 0 || height == 0 || raw_size / height != row_bytes + 1 || raw_size > 0x7FFFFFFFu / 2)
        return "image size out of range";
    raw = (unsigned char *)malloc(raw_size);
    scratch = (unsigned char *)malloc(5 * row_bytes);
    /* Fixed codes take at most 9 bits per byte; then zlib's 2 header and 4 trailer bytes. */
    chunk = (unsigned char *)malloc(8 + 2 + raw_size + raw_size / 8 + 16 + 4 + 4);
    if (!raw || !scratch || !chunk) {
        error = "out of memory";
        goto done;
    }
    for (y = 0; y < height; ++y)
        filter_row(rgb + y * row_bytes, y ? rgb + (y - 1) * row_bytes : NULL, row_bytes, scratch,
                   raw + y * (row_bytes + 1));

    w.out = chunk + 8;
    w.out[w.size++] = 0x78; /* CMF: deflate, 32 K window */
    w.out[w.size++] = 0x01; /* FLG: no dictionary, and CMF * 256 + FLG divisible by 31 */
    if (!deflate_fixed(&w, raw, raw_size)) {
        error = "out of memory";
        goto done;
    }
    adler = png_adler32(1, raw, raw_size);
    put_u32(w.out + w.size, adler);
    w.size += 4;

    put_u32(ihdr + 8, width);
    put_u32(ihdr + 12, height);
    ihdr[16] = 8; /* bit depth */
    ihdr[17] = 2; /* colour type: RGB */
    ihdr[18] = ihdr[19] = ihdr[20] = 0; /* deflate, adaptive filtering, no interlace */

    f = fopen(path, "wb");
    if (!f) {
        error = "cannot open the output file";
        goto done;
    }
    if (fwrite(signature, 1, 8, f) != 8 || !write_chunk(f, "IHDR", ihdr + 8, 13) ||
        !write_chunk(f, "IDAT", chunk + 8, w.size) || !write_chunk(f, "IEND", iend + 8, 0))
        error = "cannot write the output file";
    if (fclose(f) != 0 && !error) error = "cannot write the output file";
done:
    free(raw);
    free(scratch);
    free(chunk);
    return error;
}
