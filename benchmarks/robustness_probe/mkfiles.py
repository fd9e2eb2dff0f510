"""Make the probe's bad files."""
import os, struct, zlib, socket, sys
import numpy as np, cv2
D = "/tmp/probe/files"
os.makedirs(D, exist_ok=True)

def png(path, w, h, bitdepth, colortype, bpp):
    if os.path.exists(path):
        return
    def chunk(t, data):
        return struct.pack(">I", len(data)) + t + data + struct.pack(">I", zlib.crc32(t + data) & 0xffffffff)
    comp = zlib.compressobj(9)
    row = b"\0" + b"\0" * (w * bpp)
    parts = []
    for _ in range(h):
        parts.append(comp.compress(row))
    parts.append(comp.flush())
    idat = b"".join(parts)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bitdepth, colortype, 0, 0, 0)))
        f.write(chunk(b"IDAT", idat))
        f.write(chunk(b"IEND", b""))

png(f"{D}/huge30000.png", 30000, 30000, 8, 0, 1)          # grey 8-bit, 900 Mpx
png(f"{D}/huge16rgb.png", 16000, 16000, 16, 2, 6)         # 16-bit RGB, 256 Mpx
png(f"{D}/big8000.png", 8000, 8000, 8, 0, 1)              # 64 Mpx > default 50M
# headers lying about the size
with open(f"{D}/liar.pgm", "wb") as f:
    f.write(b"P5\n60000 60000\n255\n" + b"\0" * 100)
with open(f"{D}/liar.ppm", "wb") as f:
    f.write(b"P6\n40000 40000\n65535\n" + b"\0" * 100)
bmp = bytearray(cv2.imencode(".bmp", np.zeros((4, 4), np.uint8))[1].tobytes())
struct.pack_into("<ii", bmp, 18, 50000, 50000)
open(f"{D}/liar.bmp", "wb").write(bytes(bmp))
tif = cv2.imencode(".tiff", np.zeros((4, 4), np.uint8))[1].tobytes()
open(f"{D}/small.tiff", "wb").write(tif)
# sparse 40 GB files
for name in ("sparse40g.png", "sparse40g.pfm", "sparse40g.txt", "sparse40g.yml", "sparse40g.csv"):
    with open(f"{D}/{name}", "wb") as f:
        if name.endswith(".pfm"):
            f.write(b"Pf\n100 100\n-1.0\n")
        if name.endswith(".yml"):
            f.write(b"%YAML:1.0\n---\n")
        if name.endswith(".txt"):
            f.write(b"P0: 1 0 0 0 0 1 0 0 0 0 1 0\n")
        if name.endswith(".csv"):
            f.write(b"left,right\n")
        f.truncate(40 * 2**30)
for name in ("fifo.png", "fifo.yml", "fifo.pfm", "fifo.txt", "fifo.csv"):
    p = f"{D}/{name}"
    if not os.path.exists(p):
        os.mkfifo(p)
for name in ("loop.png", "loop.yml"):
    p = f"{D}/{name}"
    if not os.path.lexists(p):
        os.symlink(p, p)
sp = f"{D}/socket.png"
if not os.path.exists(sp):
    s = socket.socket(socket.AF_UNIX); s.bind(sp)
# good images
rng = np.random.default_rng(0)
noise = cv2.GaussianBlur(rng.uniform(0, 255, (240, 320)).astype(np.float32), (0, 0), 1.5)
noise = cv2.normalize(noise, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
cv2.imwrite(f"{D}/L.png", noise)
cv2.imwrite(f"{D}/R.png", np.roll(noise, -6, axis=1))
os.makedirs(f"{D}/adir.png", exist_ok=True)
open(f"{D}/empty.png", "wb").close()
open(f"{D}/garbage.png", "wb").write(b"not an image at all" * 10)
print("ok")
# fuzzing the API (2026-12-07): a tiny pair, and a FileStorage text nested 50,000 deep
cv2.imwrite(f"{D}/tiny20.png", noise[:20, :20])
with open(f"{D}/deep.yml", "w") as fh:
    fh.write("%YAML:1.0\n---\na: " + "[" * 50000 + "]" * 50000 + "\n")
