/* Procedural test meshes and textures for the supermat_uv.h tests (C++11), and their pass/fail
   counting. World Z up. */
#ifndef UV_MESHES_H
#define UV_MESHES_H
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

static int g_fail = 0, g_pass = 0;
#define CHECK(cond, ...)                                                                   \
    do {                                                                                   \
        if (cond) g_pass++;                                                                \
        else { g_fail++; std::printf("FAIL %s:%d: ", __FILE__, __LINE__); std::printf(__VA_ARGS__); std::printf("\n"); } \
    } while (0)

struct UvMesh {
    std::vector<float> pos, uv, nrm; /* xyz, uv, xyz per vertex */
    std::vector<uint32_t> idx;       /* triangles */
    uint32_t nv() const { return (uint32_t)(pos.size() / 3); }
    void vert(double x, double y, double z, double u, double v, double nx = 0, double ny = 0, double nz = 0) {
        pos.push_back((float)x); pos.push_back((float)y); pos.push_back((float)z);
        uv.push_back((float)u); uv.push_back((float)v);
        nrm.push_back((float)nx); nrm.push_back((float)ny); nrm.push_back((float)nz);
    }
    void tri(uint32_t a, uint32_t b, uint32_t c) { idx.push_back(a); idx.push_back(b); idx.push_back(c); }
    void transform(double s, double tx = 0, double ty = 0, double tz = 0) {
        for (size_t i = 0; i < pos.size(); i += 3) {
            pos[i] = (float)(pos[i] * s + tx); pos[i + 1] = (float)(pos[i + 1] * s + ty); pos[i + 2] = (float)(pos[i + 2] * s + tz);
        }
    }
    void append(const UvMesh &m) {
        uint32_t b = nv();
        pos.insert(pos.end(), m.pos.begin(), m.pos.end());
        uv.insert(uv.end(), m.uv.begin(), m.uv.end());
        nrm.insert(nrm.end(), m.nrm.begin(), m.nrm.end());
        for (uint32_t i : m.idx) idx.push_back(b + i);
    }
};

static const double UV_PI = 3.14159265358979323846;

/* a cube [-1,1]^3, every face its own UV chart in a 3x2 grid of tiles (inset by `margin`) */
inline UvMesh uv_cube(double margin = 0.03) {
    UvMesh m;
    static const double F[6][9] = { /* normal, tangent a, tangent b */
        {0, -1, 0, 1, 0, 0, 0, 0, 1}, {1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 1, 0, -1, 0, 0, 0, 0, 1},
        {-1, 0, 0, 0, -1, 0, 0, 0, 1}, {0, 0, 1, 1, 0, 0, 0, 1, 0}, {0, 0, -1, 1, 0, 0, 0, -1, 0}};
    for (int f = 0; f < 6; f++) {
        const double *n = F[f], *a = F[f] + 3, *b = F[f] + 6;
        double u0 = (f % 3) / 3.0, v0 = (f / 3) / 2.0, su = 1.0 / 3.0 - 2 * margin, sv = 0.5 - 2 * margin;
        uint32_t base = m.nv();
        for (int k = 0; k < 4; k++) {
            double s = (k == 1 || k == 2) ? 1 : -1, t = (k >= 2) ? 1 : -1;
            /* image rows go down: t = +1 (up on the face) maps to the smaller v */
            m.vert(n[0] + s * a[0] + t * b[0], n[1] + s * a[1] + t * b[1], n[2] + s * a[2] + t * b[2],
                   u0 + margin + (s + 1) / 2 * su, v0 + margin + (1 - t) / 2 * sv, n[0], n[1], n[2]);
        }
        m.tri(base, base + 1, base + 2);
        m.tri(base, base + 2, base + 3);
    }
    return m;
}

/* a UV sphere of radius 1 (the pole quads give zero-area triangles: 2 * nl of them) */
inline UvMesh uv_sphere(int nl = 48, int nt = 24) {
    UvMesh m;
    for (int j = 0; j <= nt; j++)
        for (int i = 0; i <= nl; i++) {
            double th = UV_PI * j / nt, ph = 2 * UV_PI * i / nl;
            double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph), z = std::cos(th);
            if (j == 0 || j == nt) { x = 0; y = 0; }
            m.vert(x, y, z, (double)i / nl, (double)j / nt, x, y, z);
        }
    for (int j = 0; j < nt; j++)
        for (int i = 0; i < nl; i++) {
            uint32_t a = j * (nl + 1) + i, b = a + 1, c = a + nl + 1, d = c + 1;
            m.tri(a, c, b);
            m.tri(b, c, d);
        }
    return m;
}

/* a torus in the XY plane: seams in u (around the ring) and v (around the tube) */
inline UvMesh uv_torus(double R = 1.0, double r = 0.45, int nu = 64, int nv = 32) {
    UvMesh m;
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i <= nu; i++) {
            double a = 2 * UV_PI * i / nu, b = 2 * UV_PI * j / nv;
            double cx = std::cos(a), cy = std::sin(a);
            m.vert((R + r * std::cos(b)) * cx, (R + r * std::cos(b)) * cy, r * std::sin(b), (double)i / nu, (double)j / nv,
                   std::cos(b) * cx, std::cos(b) * cy, std::sin(b));
        }
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            uint32_t a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
            m.tri(a, b, c);
            m.tri(b, d, c);
        }
    return m;
}

/* a smooth texture, periodic in u and v (so repeat wrapping is seamless) */
inline void uv_smooth_color(double u, double v, double out[3]) {
    out[0] = 0.5 + 0.3 * std::sin(2 * UV_PI * u + 0.3);
    out[1] = 0.5 + 0.3 * std::sin(2 * UV_PI * v + 1.1);
    out[2] = 0.5 + 0.2 * std::sin(2 * UV_PI * (u + v) + 2.0);
}
inline std::vector<unsigned char> uv_smooth_texture(int w, int h, int ch = 3) {
    std::vector<unsigned char> t((size_t)w * h * ch);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double c[3];
            uv_smooth_color((x + 0.5) / w, (y + 0.5) / h, c);
            for (int k = 0; k < ch; k++) t[((size_t)y * w + x) * ch + k] = k < 3 ? (unsigned char)std::lround(c[k] * 255) : 255;
        }
    return t;
}
#endif
