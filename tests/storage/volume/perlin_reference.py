#!/usr/bin/env python3
"""An independent transcription of the Perlin field of storage/volume/generate.h.

Recomputes the golden values hard-coded in tests/storage/volume/generate_test.cc
from the written description alone: SplitMix64, a Fisher-Yates shuffle of
0..255, a shift in [0, 256) per octave and axis, Ken Perlin's reference
improved noise (2002, transcribed from his Java code) in 3D and its 4D
analogue with the 32 edge-midpoint gradients, octaves of doubling frequency
and halving amplitude, and the map of [-spread, spread] to [0, 255].

Python floats are IEEE 754 doubles and every operation below is done in the
same order as in C++, so the values agree to the last bit.

    python3 tests/storage/volume/perlin_reference.py
"""
import math

MASK = (1 << 64) - 1


class SplitMix64:
    def __init__(self, seed):
        self.state = seed & MASK

    def next(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def next_unit(self):
        return float(self.next() >> 11) * 2.0**-53


def fade(t):
    return t * t * t * (t * (t * 6 - 15) + 10)


def lerp(t, a, b):
    return a + t * (b - a)


def grad3(h, x, y, z):
    h &= 15
    u = x if h < 8 else y
    v = y if h < 4 else (x if h in (12, 14) else z)
    return (u if h & 1 == 0 else -u) + (v if h & 2 == 0 else -v)


def grad4(h, x, y, z, w):
    h &= 31
    a, b, c = [(y, z, w), (x, z, w), (x, y, w), (x, y, z)][h >> 3]
    return (a if h & 4 == 0 else -a) + (b if h & 2 == 0 else -b) + (c if h & 1 == 0 else -c)


class Perlin:
    def __init__(self, dims, dimension, seed, octaves, frequency):
        self.dimension, self.octaves = dimension, octaves
        longest = max(1, *(dims[i] - 1 for i in range(dimension)))
        self.scale = frequency / longest
        rng = SplitMix64(seed)
        perm = list(range(256))
        for i in range(255, 0, -1):
            j = rng.next() % (i + 1)
            perm[i], perm[j] = perm[j], perm[i]
        self.p = perm + perm
        self.shift = [[rng.next_unit() * 256 for _ in range(4)] for _ in range(16)]

    def noise3(self, x, y, z):
        p = self.p
        fx, fy, fz = math.floor(x), math.floor(y), math.floor(z)
        X, Y, Z = int(fx) % 256, int(fy) % 256, int(fz) % 256
        x, y, z = x - fx, y - fy, z - fz
        u, v, w = fade(x), fade(y), fade(z)
        A = p[X] + Y; AA = p[A] + Z; AB = p[A + 1] + Z
        B = p[X + 1] + Y; BA = p[B] + Z; BB = p[B + 1] + Z
        return lerp(w, lerp(v, lerp(u, grad3(p[AA], x, y, z), grad3(p[BA], x - 1, y, z)),
                               lerp(u, grad3(p[AB], x, y - 1, z), grad3(p[BB], x - 1, y - 1, z))),
                       lerp(v, lerp(u, grad3(p[AA + 1], x, y, z - 1), grad3(p[BA + 1], x - 1, y, z - 1)),
                               lerp(u, grad3(p[AB + 1], x, y - 1, z - 1),
                                    grad3(p[BB + 1], x - 1, y - 1, z - 1))))

    def noise4(self, x, y, z, w):
        p = self.p
        f = [math.floor(x), math.floor(y), math.floor(z), math.floor(w)]
        X, Y, Z, W = (int(v) % 256 for v in f)
        r = [x - f[0], y - f[1], z - f[2], w - f[3]]
        fd = [fade(v) for v in r]
        c = []
        for k in range(16):
            i, j, l, m = k & 1, (k >> 1) & 1, (k >> 2) & 1, (k >> 3) & 1
            h = p[p[p[p[X + i] + Y + j] + Z + l] + W + m]
            c.append(grad4(h, r[0] - i, r[1] - j, r[2] - l, r[3] - m))
        n = 16
        for axis in range(4):
            c = [lerp(fd[axis], c[2 * k], c[2 * k + 1]) for k in range(n // 2)]
            n //= 2
        return c[0]

    def at(self, x, y, z, t=0):
        total, amplitude, frequency = 0.0, 1.0, self.scale
        for o in range(self.octaves):
            s = self.shift[o]
            px, py, pz = x * frequency + s[0], y * frequency + s[1], z * frequency + s[2]
            if self.dimension == 4:
                n = self.noise4(px, py, pz, t * frequency + s[3])
            else:
                n = self.noise3(px, py, pz)
            total += amplitude * n
            amplitude *= 0.5
            frequency *= 2
        spread = 1.2 if self.dimension == 4 else 1.0
        return min(max(127.5 + 127.5 * (total / spread), 0.0), 255.0)


if __name__ == "__main__":
    g3 = Perlin([65, 65, 65, 1], 3, seed=1, octaves=4, frequency=4.0)
    for pt in [(0, 0, 0), (32, 32, 32), (64, 64, 64), (1, 2, 3), (10, 50, 20), (63, 5, 41)]:
        print("3D", pt, repr(g3.at(*pt)))
    g4 = Perlin([17, 17, 17, 9], 4, seed=42, octaves=3, frequency=2.5)
    for pt in [(0, 0, 0, 0), (8, 8, 8, 4), (16, 16, 16, 8), (3, 11, 7, 2), (15, 0, 9, 6)]:
        print("4D", pt, repr(g4.at(*pt)))
