/* Tests of supermat_uv.h (C++11; Embree 3 and OpenImageIO are used here only).
   usage: test_uv OUTDIR [TINY_MV TINY_UV]   (with the two models: the full network path only) */
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"

#include "uv/uv_meshes.h"

#include <embree3/rtcore.h>
#include <OpenImageIO/imageio.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>


static std::string g_out = ".";

/* ---- images (OpenImageIO) --------------------------------------------------------------------- */
static void write_png(const std::string &path, const float *data, int w, int h, int ch) {
    std::vector<unsigned char> b((size_t)w * h * ch);
    for (size_t i = 0; i < b.size(); i++) {
        float v = data[i];
        v = v < 0 ? 0 : v > 1 ? 1 : v;
        b[i] = (unsigned char)(v * 255 + 0.5f);
    }
    auto out = OIIO::ImageOutput::create(path);
    if (!out) return;
    OIIO::ImageSpec spec(w, h, ch, OIIO::TypeDesc::UINT8);
    if (ch == 4) spec.attribute("oiio:UnassociatedAlpha", 1);
    if (out->open(path, spec)) { out->write_image(OIIO::TypeDesc::UINT8, b.data()); out->close(); }
}

/* ---- the bake with every debug image captured ------------------------------------------------- */
struct Capture {
    std::vector<float> img[SUPERMAT_UV_DEBUG_COUNT][8];
    int w[SUPERMAT_UV_DEBUG_COUNT][8], h[SUPERMAT_UV_DEBUG_COUNT][8], c[SUPERMAT_UV_DEBUG_COUNT][8];
};
static void capture_cb(void *user, supermat_uv_debug_kind k, int index, const float *data, int w, int h, int c) {
    Capture *cap = (Capture *)user;
    if (index < 0 || index >= 8) return;
    cap->img[k][index].assign(data, data + (size_t)w * h * c);
    cap->w[k][index] = w; cap->h[k][index] = h; cap->c[k][index] = c;
}

struct Bake {
    supermat_uv_part part;
    supermat_uv_bake_desc desc;
    supermat_uv_output out;
    supermat_uv_stats stats;
    supermat_error err;
    std::vector<unsigned char> albedo, mr;
    Capture cap;
};

static void setup(Bake &b, const UvMesh &m, const std::vector<unsigned char> &tex, int tw, int th, int tex_size, int view_size) {
    std::memset(&b.part, 0, sizeof b.part);
    std::memset(&b.desc, 0, sizeof b.desc);
    std::memset(&b.out, 0, sizeof b.out);
    std::memset(&b.stats, 0, sizeof b.stats);
    b.part.positions = m.pos.data(); b.part.uvs = m.uv.data(); b.part.vertex_count = m.nv();
    b.part.indices = m.idx.data(); b.part.index_count = (uint32_t)m.idx.size();
    b.part.base_color.pixels = (void *)tex.data(); b.part.base_color.width = tw; b.part.base_color.height = th;
    b.part.base_color.channels = (int)(tex.size() / ((size_t)tw * th));
    b.desc.parts = &b.part; b.desc.part_count = 1;
    b.desc.texture_width = b.desc.texture_height = tex_size;
    b.desc.view_size = view_size;
    b.desc.passthrough = 1;
    b.desc.threads = 2;
    b.desc.debug = capture_cb; b.desc.debug_user = &b.cap;
    b.albedo.assign((size_t)tex_size * tex_size * 3, 0);
    b.mr.assign((size_t)tex_size * tex_size * 3, 0);
    b.out.base_color.pixels = b.albedo.data(); b.out.base_color.channels = 3;
    b.out.metallic_roughness.pixels = b.mr.data(); b.out.metallic_roughness.channels = 3;
}
static supermat_result run(Bake &b) { return supermat_uv_bake(&b.desc, &b.out, &b.stats, &b.err); }

static void dump(const Bake &b, const std::string &name) {
    const Capture &c = b.cap;
    for (int v = 0; v < SUPERMAT_UV_VIEWS; v++)
        if (!c.img[SUPERMAT_UV_DEBUG_VIEW][v].empty())
            write_png(g_out + "/" + name + "_view_" + std::to_string(v) + ".png", c.img[SUPERMAT_UV_DEBUG_VIEW][v].data(),
                      c.w[SUPERMAT_UV_DEBUG_VIEW][v], c.h[SUPERMAT_UV_DEBUG_VIEW][v], 4);
    int K[4] = {SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO, SUPERMAT_UV_DEBUG_MASK, SUPERMAT_UV_DEBUG_POSITION, SUPERMAT_UV_DEBUG_PARTIAL_RM};
    const char *N[4] = {"partial_albedo", "mask", "position", "partial_rm"};
    for (int k = 0; k < 4; k++)
        if (!c.img[K[k]][0].empty()) write_png(g_out + "/" + name + "_" + N[k] + ".png", c.img[K[k]][0].data(), c.w[K[k]][0], c.h[K[k]][0], c.c[K[k]][0]);
    std::vector<float> a(b.albedo.size());
    for (size_t i = 0; i < a.size(); i++) a[i] = b.albedo[i] / 255.0f;
    int ts = b.desc.texture_width;
    write_png(g_out + "/" + name + "_albedo.png", a.data(), ts, ts, 3);
}

/* ---- Embree ----------------------------------------------------------------------------------- */
struct Rt {
    RTCDevice dev;
    RTCScene scene;
    std::vector<float> q; /* view frame positions */
    const UvMesh *m;
    Rt(const UvMesh &mesh, const supermat_uv_stats &st) : m(&mesh) {
        dev = rtcNewDevice(NULL);
        scene = rtcNewScene(dev);
        rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *vb = (float *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.nv());
        unsigned *ib = (unsigned *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.idx.size() / 3);
        q.resize(mesh.pos.size());
        for (size_t i = 0; i < mesh.pos.size(); i++) {
            q[i] = (float)((mesh.pos[i] - st.view_center[i % 3]) * st.view_scale);
            vb[i] = q[i];
        }
        for (size_t i = 0; i < mesh.idx.size(); i++) ib[i] = mesh.idx[i];
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(scene);
    }
    ~Rt() { rtcReleaseScene(scene); rtcReleaseDevice(dev); }
    /* nearest hit distance along dir from org, or -1 */
    double hit(const double org[3], const double dir[3], double tnear) const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh;
        std::memset(&rh, 0, sizeof rh);
        rh.ray.org_x = (float)org[0]; rh.ray.org_y = (float)org[1]; rh.ray.org_z = (float)org[2];
        rh.ray.dir_x = (float)dir[0]; rh.ray.dir_y = (float)dir[1]; rh.ray.dir_z = (float)dir[2];
        rh.ray.tnear = (float)tnear; rh.ray.tfar = 1e30f; rh.ray.mask = 0xFFFFFFFFu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &ctx, &rh);
        return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1.0 : rh.ray.tfar;
    }
};

struct Cam { double X[3], Y[3], Z[3], T[3]; };
static Cam camera(int v) {
    float m[96];
    supermat_uv_cameras(m);
    Cam c;
    for (int k = 0; k < 3; k++) { c.X[k] = m[v * 16 + 4 * k]; c.Y[k] = m[v * 16 + 4 * k + 1]; c.Z[k] = m[v * 16 + 4 * k + 2]; c.T[k] = m[v * 16 + 4 * k + 3]; }
    return c;
}

/* ---- 1. cameras ------------------------------------------------------------------------------- */
static void test_cameras() {
    /* examples/bag_rendered_6views/meta.json of the official repository, locations[i].transform_matrix */
    static const double meta[6][16] = {
        {1.0, 0.0, 6.123233601181349e-17, 6.123234262925839e-17, 6.123233601181349e-17, 3.422854177870249e-08, -0.9999999403953552, -1.0, 0.0, 0.9999999403953552, 3.422854177870249e-08, 0.0, 0.0, 0.0, 0.0, 1.0},
        {1.1920928244535389e-07, 0.0, 0.9999998807907104, 1.0, 0.9999998807907104, 1.1920928244535389e-07, 0.0, 0.0, 0.0, 0.9999998807907104, 1.1920928244535389e-07, 0.0, 0.0, 0.0, 0.0, 1.0},
        {-0.9999999403953552, 8.742277657347586e-08, 0.0, 6.123234262925839e-17, 0.0, 3.4228538225988814e-08, 0.9999999403953552, 1.0, 8.742277657347586e-08, 0.9999999403953552, 3.4228538225988814e-08, 0.0, 0.0, 0.0, 0.0, 1.0},
        {5.9604641222676946e-08, 0.0, -0.9999999403953552, -1.0, -0.9999999403953552, 1.1920928244535389e-07, 0.0, 1.2246468525851679e-16, 5.9604641222676946e-08, 0.9999999403953552, 5.9604641222676946e-08, 0.0, 0.0, 0.0, 0.0, 1.0},
        {-1.0000001192092896, 8.742277657347586e-08, 1.5258152380459578e-11, 1.0687059615292178e-20, -8.742277657347586e-08, -1.0, -0.0003490658418741077, -0.00017453292093705386, -1.5258152380459578e-11, -0.0003490658418741077, 0.9999999403953552, 1.0, 0.0, 0.0, 0.0, 1.0},
        {-1.0000001192092896, -8.742277657347586e-08, 1.526579557209473e-11, 1.0687059615292178e-20, -8.742277657347586e-08, 0.9999999403953552, -0.00034915326978079975, -0.00017453292093705386, 1.5258152380459578e-11, -0.00034915326978079975, -1.0, -1.0, 0.0, 0.0, 0.0, 1.0}};
    float m[96];
    supermat_uv_cameras(m);
    double worst = 0;
    for (int i = 0; i < 96; i++) worst = std::fmax(worst, std::fabs(m[i] - meta[i / 16][i % 16]));
    CHECK(worst <= 1e-6, "camera matrices differ from meta.json by %g", worst);
    /* the documented layout: front camera at -Y, right +X, back +Y, left -X, top +Z, bottom -Z */
    static const double pos[6][3] = {{0, -1, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int v = 0; v < 6; v++) {
        Cam c = camera(v);
        double e = 0;
        for (int k = 0; k < 3; k++) e = std::fmax(e, std::fabs(c.T[k] - pos[v][k]));
        CHECK(e < 1e-3, "camera %d is not where documented", v);
    }
    /* top and bottom views are tilted by about 0.02 degrees */
    Cam top = camera(4);
    double tilt = std::acos(top.Z[2]) * 180 / UV_PI;
    CHECK(tilt > 0.015 && tilt < 0.025, "top tilt %g degrees", tilt);
    std::printf("cameras: max |difference| to meta.json %.3g (float32 storage), top tilt %.4f deg\n", worst, tilt);
}

/* ---- 2. rendering vs Embree ------------------------------------------------------------------- */
static void test_render_vs_embree() {
    /* a torus with a sphere through its hole and a box behind: silhouettes, holes, occlusion */
    UvMesh m = uv_torus(1.0, 0.35, 48, 24);
    UvMesh s = uv_sphere(32, 16);
    s.transform(0.5, 0.2, -0.3, 0.1);
    m.append(s);
    UvMesh c = uv_cube();
    c.transform(0.3, -0.9, 0.9, -0.2);
    m.append(c);
    std::vector<unsigned char> tex = uv_smooth_texture(64, 64);
    Bake b;
    int V = 160;
    setup(b, m, tex, 64, 64, 64, V);
    supermat_result r = run(b);
    CHECK(r == SUPERMAT_SUCCESS, "render bake failed: %s", b.err.message);
    if (r) return;
    dump(b, "render");
    Rt rt(m, b.stats);
    double hw = 1.1, worst_depth = 0;
    long total = 0, agree = 0, alpha_agree = 0, edge_px = 0;
    for (int v = 0; v < 6; v++) {
        Cam cm = camera(v);
        const std::vector<float> &dep = b.cap.img[SUPERMAT_UV_DEBUG_VIEW_DEPTH][v], &rgba = b.cap.img[SUPERMAT_UV_DEBUG_VIEW][v];
        std::vector<double> et((size_t)V * V);
        for (int y = 0; y < V; y++)
            for (int x = 0; x < V; x++) {
                double xc = ((x + 0.5) / V * 2 - 1) * hw, yc = (1 - (y + 0.5) / V * 2) * hw, org[3], dir[3];
                for (int k = 0; k < 3; k++) { org[k] = cm.T[k] + xc * cm.X[k] + yc * cm.Y[k] + 10 * cm.Z[k]; dir[k] = -cm.Z[k]; }
                double t = rt.hit(org, dir, 0);
                et[(size_t)y * V + x] = t < 0 ? -1 : t - 10;
            }
        for (int y = 1; y < V - 1; y++)
            for (int x = 1; x < V - 1; x++) {
                bool h = et[(size_t)y * V + x] > -1, mixed = false;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        size_t k = (size_t)(y + dy) * V + x + dx;
                        if ((et[k] > -1) != h) mixed = true;
                        /* depth edges: a neighbour more than 3 pixels of depth away */
                        if (h && et[k] > -1 && std::fabs(et[k] - et[(size_t)y * V + x]) > 3 * 2.2 / V) mixed = true;
                    }
                if (mixed) { edge_px++; continue; }
                size_t k = (size_t)y * V + x;
                bool ours = std::isfinite(dep[k]);
                total++;
                if (ours == h) agree++;
                if ((rgba[k * 4 + 3] >= 0.5f) == h) alpha_agree++;
                if (ours && h) worst_depth = std::fmax(worst_depth, std::fabs(dep[k] - et[k]));
            }
    }
    double a = (double)agree / total, aa = (double)alpha_agree / total;
    std::printf("render vs Embree: %ld pixels away from edges (%ld edge pixels left out): silhouette agreement %.4f%%, "
                "alpha>=0.5 agreement %.4f%%, max depth error %.3g (view frame; pixel = %.3g)\n",
                total, edge_px, 100 * a, 100 * aa, worst_depth, 2.2 / V);
    CHECK(a >= 0.995, "silhouette agreement %g", a);
    CHECK(aa >= 0.995, "alpha agreement %g", aa);
    CHECK(worst_depth <= 1e-4, "depth error %g", worst_depth);
}

/* ---- 3. passthrough round trip + coverage vs Embree ------------------------------------------- */
struct TexelPoint { bool chart; double q[3], n[3]; };
/* an independent UV rasteriser (inclusive barycentric test): the first triangle covering each texel centre */
static std::vector<TexelPoint> texel_points(const UvMesh &m, const std::vector<float> &q, int ts) {
    std::vector<TexelPoint> tp((size_t)ts * ts);
    for (auto &t : tp) t.chart = false;
    for (size_t f = 0; f < m.idx.size() / 3; f++) {
        const uint32_t *ix = &m.idx[3 * f];
        double u[3], v[3];
        for (int k = 0; k < 3; k++) { u[k] = m.uv[2 * ix[k]] * ts; v[k] = m.uv[2 * ix[k] + 1] * ts; }
        double det = (u[1] - u[0]) * (v[2] - v[0]) - (u[2] - u[0]) * (v[1] - v[0]);
        double e1[3], e2[3], n[3];
        for (int k = 0; k < 3; k++) { e1[k] = q[3 * ix[1] + k] - q[3 * ix[0] + k]; e2[k] = q[3 * ix[2] + k] - q[3 * ix[0] + k]; }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1]; n[1] = e1[2] * e2[0] - e1[0] * e2[2]; n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double ln = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (det == 0 || ln < 1e-12) continue;
        int x0 = (int)std::floor(std::fmin(u[0], std::fmin(u[1], u[2]))), x1 = (int)std::ceil(std::fmax(u[0], std::fmax(u[1], u[2])));
        int y0 = (int)std::floor(std::fmin(v[0], std::fmin(v[1], v[2]))), y1 = (int)std::ceil(std::fmax(v[0], std::fmax(v[1], v[2])));
        for (int y = y0; y <= y1; y++)
            for (int x = x0; x <= x1; x++) {
                double px = x + 0.5, py = y + 0.5;
                double b1 = ((px - u[0]) * (v[2] - v[0]) - (u[2] - u[0]) * (py - v[0])) / det;
                double b2 = ((u[1] - u[0]) * (py - v[0]) - (px - u[0]) * (v[1] - v[0])) / det;
                double b0 = 1 - b1 - b2;
                if (b0 < -1e-9 || b1 < -1e-9 || b2 < -1e-9) continue;
                int xw = ((x % ts) + ts) % ts, yw = ((y % ts) + ts) % ts;
                TexelPoint &t = tp[(size_t)yw * ts + xw];
                if (t.chart) continue;
                t.chart = true;
                for (int k = 0; k < 3; k++) {
                    t.q[k] = b0 * q[3 * ix[0] + k] + b1 * q[3 * ix[1] + k] + b2 * q[3 * ix[2] + k];
                    t.n[k] = n[k] / ln;
                }
            }
    }
    return tp;
}

static double psnr_of(double mse) { return mse > 0 ? 10 * std::log10(1.0 / mse) : 99.0; }

static void roundtrip(const char *name, const UvMesh &m, int view_size, double min_psnr) {
    int ts = 256;
    std::vector<unsigned char> tex = uv_smooth_texture(ts, ts);
    Bake b;
    setup(b, m, tex, ts, ts, ts, view_size);
    b.part.normals = m.nrm.data();
    auto t0 = std::chrono::steady_clock::now();
    supermat_result r = run(b);
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CHECK(r == SUPERMAT_SUCCESS, "%s: bake failed: %s", name, b.err.message);
    if (r) return;
    dump(b, name);
    const std::vector<float> &pa = b.cap.img[SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO][0], &mask = b.cap.img[SUPERMAT_UV_DEBUG_MASK][0],
                             &seen = b.cap.img[SUPERMAT_UV_DEBUG_SEEN][0], &chart = b.cap.img[SUPERMAT_UV_DEBUG_CHART][0];
    /* PSNR of the blended back-projection vs the source texture on covered texels */
    double se = 0, se8 = 0;
    long n = 0;
    for (size_t i = 0; i < (size_t)ts * ts; i++) {
        if (mask[i] <= 0) continue;
        for (int c = 0; c < 3; c++) {
            double d = pa[i * 3 + c] - tex[i * 3 + c] / 255.0, d8 = b.albedo[i * 3 + c] / 255.0 - tex[i * 3 + c] / 255.0;
            se += d * d; se8 += d8 * d8;
        }
        n++;
    }
    double psnr = psnr_of(se / (3.0 * n)), psnr8 = psnr_of(se8 / (3.0 * n));
    if (getenv("UV_DIAG"))
        for (int y = 0; y < ts; y++) {
            double e = 0; long k = 0;
            for (int x = 0; x < ts; x++) {
                size_t i = (size_t)y * ts + x;
                if (mask[i] <= 0) continue;
                for (int c = 0; c < 3; c++) { double d = pa[i * 3 + c] - tex[i * 3 + c] / 255.0; e += d * d; }
                k++;
            }
            if (k) std::printf("row %s %d mse %.3g n %ld\n", name, y, e / (3.0 * k), k);
        }
    /* coverage vs Embree: per texel (any view) and per (texel, view) */
    Rt rt(m, b.stats);
    std::vector<TexelPoint> tp = texel_points(m, rt.q, ts);
    long chart_both = 0, chart_diff = 0, any_agree = 0, pair_agree = 0, pairs = 0, emb_any = 0, ours_any = 0;
    for (size_t i = 0; i < (size_t)ts * ts; i++) {
        bool oc = chart[i] > 0;
        if (oc != tp[i].chart) chart_diff++;
        if (!(oc && tp[i].chart)) continue;
        chart_both++;
        unsigned sb = (unsigned)seen[i], eb = 0;
        for (int v = 0; v < 6; v++) {
            Cam c = camera(v);
            double cs = tp[i].n[0] * c.Z[0] + tp[i].n[1] * c.Z[1] + tp[i].n[2] * c.Z[2];
            if (std::fabs(cs) < 0.02) continue; /* the header's documented edge-on limit */
            if (rt.hit(tp[i].q, c.Z, 1e-4) < 0) eb |= 1u << v;
        }
        for (int v = 0; v < 6; v++) {
            pairs++;
            if (((sb >> v) & 1) == ((eb >> v) & 1)) pair_agree++;
            else if (getenv("UV_DIAG")) {
                Cam c = camera(v);
                double cs = tp[i].n[0] * c.Z[0] + tp[i].n[1] * c.Z[1] + tp[i].n[2] * c.Z[2];
                std::printf("diag %s texel %zu view %d ours %u embree %u cos %.4f\n", name, i, v, (sb >> v) & 1, (eb >> v) & 1, cs);
            }
        }
        if ((sb != 0) == (eb != 0)) any_agree++;
        if (eb) emb_any++;
        if (sb) ours_any++;
    }
    double cov = (double)any_agree / chart_both, pair = (double)pair_agree / pairs;
    std::printf("%s (view %d, texture %d, %.2f s): PSNR %.2f dB float / %.2f dB 8-bit output over %ld seen texels; "
                "coverage vs Embree: per texel %.3f%% (seen: ours %ld, Embree %ld of %ld), per (texel, view) %.3f%%; "
                "chart texels differing from an independent rasteriser: %ld; degenerate triangles %u\n",
                name, view_size, ts, secs, psnr, psnr8, n, 100 * cov, ours_any, emb_any, chart_both, 100 * pair, chart_diff,
                b.stats.triangles_degenerate);
    CHECK(psnr >= min_psnr, "%s: PSNR %g < %g", name, psnr, min_psnr);
    CHECK(cov >= 0.995, "%s: per-texel coverage agreement %g", name, cov);
    CHECK(pair >= 0.98, "%s: per (texel, view) agreement %g", name, pair);
    CHECK(chart_diff <= (long)(0.002 * chart_both) + 8, "%s: chart differs on %ld texels", name, chart_diff);
    /* the metallic-roughness output of the passthrough: R 1, G 0.5, B 0 everywhere */
    bool mr_ok = true;
    for (size_t i = 0; i < (size_t)ts * ts; i++)
        if (b.mr[i * 3] != 255 || b.mr[i * 3 + 1] != 128 || b.mr[i * 3 + 2] != 0) mr_ok = false;
    CHECK(mr_ok, "%s: passthrough metallic-roughness is not (1, 0.5, 0)", name);
}

static void test_roundtrip() {
    UvMesh sphere = uv_sphere(64, 32);
    roundtrip("cube", uv_cube(), 512, 35.0);
    roundtrip("sphere", sphere, 512, 35.0);
    roundtrip("torus", uv_torus(), 512, 35.0);
    /* a mesh far from the origin (the position map's official frame), and determinism across threads */
    Bake a, b;
    std::vector<unsigned char> tex = uv_smooth_texture(64, 64);
    setup(a, sphere, tex, 64, 64, 64, 64);
    setup(b, sphere, tex, 64, 64, 64, 64);
    a.desc.threads = 1; b.desc.threads = 2;
    CHECK(run(a) == SUPERMAT_SUCCESS && run(b) == SUPERMAT_SUCCESS, "thread runs failed");
    CHECK(a.albedo == b.albedo && a.mr == b.mr, "1 and 2 threads give different textures");
}

/* ---- 4. gutter -------------------------------------------------------------------------------- */
static void test_gutter() {
    /* islands on a flat plate facing the front camera: several small charts, one crossing the u = 1 edge */
    UvMesh m;
    struct Isl { double x, z, w, h, u, v, su, sv; } isl[4] = {
        {-0.8, -0.8, 0.6, 0.6, 0.10, 0.10, 0.20, 0.20}, {0.2, -0.8, 0.6, 0.6, 0.55, 0.15, 0.15, 0.30},
        {-0.8, 0.2, 0.6, 0.6, 0.30, 0.60, 0.25, 0.10}, {0.2, 0.2, 0.6, 0.6, 0.90, 0.70, 0.20, 0.20}};
    for (auto &s : isl) {
        uint32_t b = m.nv();
        m.vert(s.x, 0, s.z, s.u, s.v + s.sv);
        m.vert(s.x + s.w, 0, s.z, s.u + s.su, s.v + s.sv);
        m.vert(s.x + s.w, 0, s.z + s.h, s.u + s.su, s.v);
        m.vert(s.x, 0, s.z + s.h, s.u, s.v);
        m.tri(b, b + 1, b + 2);
        m.tri(b, b + 2, b + 3);
    }
    int ts = 128, N = 6;
    std::vector<unsigned char> tex = uv_smooth_texture(64, 64);
    Bake b;
    setup(b, m, tex, 64, 64, ts, 128);
    b.desc.gutter = N;
    supermat_result r = run(b);
    CHECK(r == SUPERMAT_SUCCESS, "gutter bake failed: %s", b.err.message);
    if (r) return;
    dump(b, "gutter");
    const std::vector<float> &seen = b.cap.img[SUPERMAT_UV_DEBUG_SEEN][0];
    long within = 0, ok = 0, beyond = 0, beyond_ok = 0;
    double mean[3] = {0, 0, 0};
    long nv = 0;
    for (int i = 0; i < ts * ts; i++)
        if (seen[i] > 0) { nv++; for (int c = 0; c < 3; c++) mean[c] += b.albedo[i * 3 + c]; }
    for (int y = 0; y < ts; y++)
        for (int x = 0; x < ts; x++) {
            int i = y * ts + x;
            if (seen[i] > 0) continue;
            bool near = false, match = false;
            for (int dy = -N; dy <= N; dy++)
                for (int dx = -N; dx <= N; dx++) {
                    int j = ((y + dy + ts) % ts) * ts + (x + dx + ts) % ts;
                    if (seen[j] <= 0) continue;
                    near = true;
                    if (!std::memcmp(&b.albedo[j * 3], &b.albedo[i * 3], 3)) match = true;
                }
            if (near) { within++; if (match) ok++; }
            else {
                beyond++;
                bool mm = true;
                for (int c = 0; c < 3; c++) if (std::abs(b.albedo[i * 3 + c] - mean[c] / nv) > 1.0) mm = false;
                if (mm) beyond_ok++;
            }
        }
    std::printf("gutter %d: %ld texels within %d of a chart, %ld hold a chart texel's colour; %ld beyond, %ld hold the mean\n",
                N, within, N, ok, beyond, beyond_ok);
    CHECK(within > 0 && ok == within, "gutter: %ld of %ld texels hold a chart colour", ok, within);
    CHECK(beyond_ok == beyond, "beyond the gutter: %ld of %ld hold the mean", beyond_ok, beyond);
}

/* ---- 5. degenerate input ---------------------------------------------------------------------- */
static bool contains(const char *s, const char *w) { return std::strstr(s, w) != NULL; }

static void test_degenerate() {
    UvMesh cube = uv_cube();
    std::vector<unsigned char> tex = uv_smooth_texture(32, 32);
    supermat_result r;
    {   /* zero-area triangles are skipped and counted */
        UvMesh m = cube;
        m.tri(0, 0, 1); m.tri(2, 2, 2); m.tri(0, 1, 0);
        Bake b; setup(b, m, tex, 32, 32, 64, 64);
        r = run(b);
        CHECK(r == SUPERMAT_SUCCESS && b.stats.triangles_degenerate == 3 && b.stats.triangles == 12,
              "zero-area triangles: r %d, %u skipped, %u used (%s)", r, b.stats.triangles_degenerate, b.stats.triangles, b.err.message);
    }
    {   /* every triangle zero area */
        UvMesh m = cube;
        m.idx.assign(6, 0);
        m.idx[2] = 1; m.idx[3] = 1; m.idx[4] = 2; m.idx[5] = 2; /* (0, 0, 1), (1, 2, 2) */
        Bake b; setup(b, m, tex, 32, 32, 64, 64);
        std::fill(b.albedo.begin(), b.albedo.end(), 77);
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "zero area"), "all zero area: %d %s", r, b.err.message);
        bool untouched = true;
        for (unsigned char c : b.albedo) if (c != 77) untouched = false;
        CHECK(untouched, "an output was written on failure");
    }
    {   /* NaN and Inf positions */
        for (int k = 0; k < 2; k++) {
            UvMesh m = cube;
            m.pos[3 * 5 + 1] = k ? INFINITY : NAN;
            Bake b; setup(b, m, tex, 32, 32, 64, 64);
            std::fill(b.mr.begin(), b.mr.end(), 77);
            r = run(b);
            CHECK(r == SUPERMAT_ERROR_NONFINITE && contains(b.err.message, "vertex 5") && contains(b.err.message, "NaN or Inf"),
                  "non-finite position: %d %s", r, b.err.message);
            CHECK(b.mr[0] == 77, "an output was written on failure");
        }
    }
    {   /* a NaN UV */
        UvMesh m = cube;
        m.uv[7] = NAN;
        Bake b; setup(b, m, tex, 32, 32, 64, 64);
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_NONFINITE && contains(b.err.message, "UV"), "NaN UV: %d %s", r, b.err.message);
    }
    {   /* index out of range */
        UvMesh m = cube;
        m.idx[10] = 24;
        Bake b; setup(b, m, tex, 32, 32, 64, 64);
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "out of range") && contains(b.err.message, "triangle 3"),
              "index out of range: %d %s", r, b.err.message);
    }
    {   /* missing UVs */
        Bake b; setup(b, cube, tex, 32, 32, 64, 64);
        b.part.uvs = NULL;
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "no UVs"), "missing UVs: %d %s", r, b.err.message);
    }
    {   /* zero triangles, bad index count, bad sizes, no mv model without passthrough, bad output size */
        Bake b; setup(b, cube, tex, 32, 32, 64, 64);
        b.part.index_count = 0;
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "no triangles"), "no triangles: %d %s", r, b.err.message);
        b.part.index_count = 7;
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "whole number"), "7 indices: %d %s", r, b.err.message);
        b.part.index_count = (uint32_t)cube.idx.size();
        b.desc.view_size = 100;
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "multiple of 8"), "view 100: %d %s", r, b.err.message);
        b.desc.view_size = 64;
        b.desc.passthrough = 0;
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_INVALID_ARGUMENT && contains(b.err.message, "mv_model"), "no model: %d %s", r, b.err.message);
        b.desc.passthrough = 1;
        b.out.base_color.width = 32;
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_BAD_IMAGE, "output size: %d %s", r, b.err.message);
    }
    {   /* no indices = a triangle list; a NaN in an unreferenced vertex does not matter */
        UvMesh m = cube, l;
        for (uint32_t i : m.idx) l.vert(m.pos[3 * i], m.pos[3 * i + 1], m.pos[3 * i + 2], m.uv[2 * i], m.uv[2 * i + 1]);
        Bake a; setup(a, m, tex, 32, 32, 64, 64);
        Bake b; setup(b, l, tex, 32, 32, 64, 64);
        b.part.indices = NULL; b.part.index_count = 0;
        CHECK(run(a) == SUPERMAT_SUCCESS && run(b) == SUPERMAT_SUCCESS && a.albedo == b.albedo, "triangle list differs from indexed");
        m.vert(NAN, 0, 0, 0, 0);
        Bake c; setup(c, m, tex, 32, 32, 64, 64);
        CHECK(run(c) == SUPERMAT_SUCCESS && c.albedo == a.albedo, "unreferenced NaN vertex: %s", c.err.message);
    }
    {   /* huge and tiny coordinates give the same textures */
        UvMesh s = uv_sphere(32, 16), big = s, tiny = s;
        big.transform(1e6, 3e6, -2e6, 1e6);
        tiny.transform(1e-6, 3e-6, -2e-6, 1e-6);
        std::vector<unsigned char> t2 = uv_smooth_texture(64, 64);
        Bake a, b, c;
        setup(a, s, t2, 64, 64, 128, 128); setup(b, big, t2, 64, 64, 128, 128); setup(c, tiny, t2, 64, 64, 128, 128);
        for (Bake *k : {&a, &b, &c}) k->desc.position_frame = SUPERMAT_UV_POSITION_CENTERED; /* the offset moves the official frame */
        CHECK(run(a) == 0 && run(b) == 0 && run(c) == 0, "scaled sphere runs failed");
        long same_b = 0, same_c = 0, n = (long)a.albedo.size();
        int worst = 0;
        for (long i = 0; i < n; i++) {
            same_b += a.albedo[i] == b.albedo[i];
            same_c += a.albedo[i] == c.albedo[i];
            worst = std::max(worst, std::max(std::abs(a.albedo[i] - b.albedo[i]), std::abs(a.albedo[i] - c.albedo[i])));
        }
        const std::vector<float> &pa = a.cap.img[SUPERMAT_UV_DEBUG_POSITION][0], &pb = b.cap.img[SUPERMAT_UV_DEBUG_POSITION][0];
        double pw = 0;
        for (size_t i = 0; i < pa.size(); i++) pw = std::fmax(pw, std::fabs(pa[i] - pb[i]));
        std::printf("scale 1e6 / 1e-6 (with an offset): %.3f%% / %.3f%% of albedo bytes identical to scale 1, max difference %d/255; "
                    "position map max difference %.2g\n", 100.0 * same_b / n, 100.0 * same_c / n, worst, pw);
        CHECK(same_b >= 0.999 * n && same_c >= 0.999 * n && worst <= 8, "scaled results differ");
        CHECK(pw < 1e-5, "position maps differ by %g", pw);
        /* a pure scale in the official frame (p / max|p|) changes nothing either */
        UvMesh big2 = s;
        big2.transform(1e6);
        Bake d2, a2;
        setup(d2, big2, t2, 64, 64, 128, 128); setup(a2, s, t2, 64, 64, 128, 128);
        CHECK(run(d2) == 0 && run(a2) == 0, "official-frame scale runs");
        const std::vector<float> &q1 = a2.cap.img[SUPERMAT_UV_DEBUG_POSITION][0], &q2 = d2.cap.img[SUPERMAT_UV_DEBUG_POSITION][0];
        double qw = 0;
        for (size_t i = 0; i < q1.size(); i++) qw = std::fmax(qw, std::fabs(q1[i] - q2[i]));
        long same2 = 0;
        for (size_t i = 0; i < a2.albedo.size(); i++) same2 += a2.albedo[i] == d2.albedo[i];
        std::printf("scale 1e6 in the official position frame: position map max difference %.2g, %.3f%% of albedo bytes identical\n",
                    qw, 100.0 * same2 / a2.albedo.size());
        CHECK(qw < 1e-5 && same2 >= (long)(0.999 * a2.albedo.size()), "official frame not scale invariant");
    }
    {   /* the official position frame: p / max|p|, not re-centred */
        UvMesh s = uv_cube();
        s.transform(2.0, 0, 0, 2.0); /* z in [0, 4]: position z in [0, 1] -> [0.5, 1] */
        Bake b; setup(b, s, tex, 32, 32, 64, 64);
        CHECK(run(b) == 0, "official frame run");
        const std::vector<float> &p = b.cap.img[SUPERMAT_UV_DEBUG_POSITION][0], &ch = b.cap.img[SUPERMAT_UV_DEBUG_CHART][0];
        double zmin = 9, zmax = -9, off = 0;
        for (size_t i = 0; i < ch.size(); i++) {
            if (ch[i] > 0) { zmin = std::fmin(zmin, p[i * 3 + 2]); zmax = std::fmax(zmax, p[i * 3 + 2]); }
            else off = std::fmax(off, std::fabs(p[i * 3] - 127 / 255.0f));
        }
        CHECK(zmin > 0.49 && zmin < 0.52 && zmax > 0.98 && off < 1e-7 && b.stats.position_scale == 0.25,
              "official position frame: z in [%g, %g], off-chart %g, scale %g", zmin, zmax, off, b.stats.position_scale);
    }
    {   /* cancellation and the memory estimate against a counting allocator */
        struct Count { size_t now = 0, peak = 0; } cnt;
        supermat_allocator al;
        al.user = &cnt;
        al.alloc = [](void *u, size_t n, size_t) -> void * {
            Count *c = (Count *)u;
            size_t *p = (size_t *)std::malloc(n + 16);
            if (!p) return NULL;
            *p = n; c->now += n; if (c->now > c->peak) c->peak = c->now;
            return (char *)p + 16;
        };
        al.free = [](void *u, void *p, size_t) { Count *c = (Count *)u; size_t *q = (size_t *)((char *)p - 16); c->now -= *q; std::free(q); };
        Bake b; setup(b, cube, tex, 32, 32, 128, 64);
        b.desc.allocator = al; b.desc.threads = 1;
        size_t est = 0;
        CHECK(supermat_uv_bake_memory(&b.desc, &est, &b.err) == 0, "memory estimate: %s", b.err.message);
        r = run(b);
        std::printf("memory: estimated %zu bytes, measured peak %zu, leaked %zu\n", est, cnt.peak, cnt.now);
        CHECK(r == 0 && cnt.now == 0 && cnt.peak <= est && est <= cnt.peak * 11 / 10, "memory estimate %zu vs peak %zu (now %zu)", est, cnt.peak, cnt.now);
        int calls = 0;
        b.desc.progress = [](void *u, float, const char *) { return ++*(int *)u >= 3 ? 1 : 0; };
        b.desc.progress_user = &calls;
        std::fill(b.albedo.begin(), b.albedo.end(), 77);
        r = run(b);
        CHECK(r == SUPERMAT_ERROR_CANCELLED && cnt.now == 0 && b.albedo[0] == 77, "cancel: %d, leaked %zu", r, cnt.now);
        /* an allocator failing at the k-th call: an error, never a crash or a leak */
        struct Fail { int k, n; Count *c; } fl = {0, 0, &cnt};
        supermat_allocator fa;
        fa.user = &fl;
        fa.alloc = [](void *u, size_t n, size_t) -> void * {
            Fail *f = (Fail *)u;
            if (f->n++ == f->k) return NULL;
            size_t *p = (size_t *)std::malloc(n + 16);
            if (!p) return NULL;
            *p = n; f->c->now += n;
            return (char *)p + 16;
        };
        fa.free = [](void *u, void *p, size_t) { Fail *f = (Fail *)u; size_t *q = (size_t *)((char *)p - 16); f->c->now -= *q; std::free(q); };
        b.desc.progress = NULL;
        b.desc.allocator = fa;
        int fails = 0, ok = 0;
        for (int k = 0; k < 60; k++) {
            fl.k = k; fl.n = 0;
            r = run(b);
            if (r == SUPERMAT_ERROR_OUT_OF_MEMORY) fails++;
            else if (r == 0) { ok++; break; }
        }
        CHECK(cnt.now == 0 && fails > 10 && ok == 1, "allocation failures: %d errors, %d successes, leaked %zu", fails, ok, cnt.now);
    }
}

/* ---- 6. UV edge cases: wrapping, mirrored and overlapping charts, several parts ---------------- */
static void test_uv_cases() {
    /* the sphere with its UVs shifted by (+2, -1): repeat wrapping gives the same texture */
    UvMesh s = uv_sphere(32, 16), sh = s;
    for (size_t i = 0; i < sh.uv.size(); i += 2) { sh.uv[i] += 2.0f; sh.uv[i + 1] -= 1.0f; }
    std::vector<unsigned char> tex = uv_smooth_texture(64, 64);
    Bake a, b;
    setup(a, s, tex, 64, 64, 64, 128); setup(b, sh, tex, 64, 64, 64, 128);
    CHECK(run(a) == 0 && run(b) == 0, "wrap runs");
    long same = 0;
    for (size_t i = 0; i < a.albedo.size(); i++) same += std::abs(a.albedo[i] - b.albedo[i]) <= 1;
    std::printf("UVs shifted by (2, -1): %.3f%% of bytes within 1/255\n", 100.0 * same / a.albedo.size());
    CHECK(same >= (long)(0.995 * a.albedo.size()), "wrapped UVs give a different texture");
    /* a mirrored, overlapping chart: the cube's +X and -X faces share the -X face's UV tile, mirrored */
    UvMesh c = uv_cube();
    for (int k = 0; k < 4; k++) { /* face 1 (+X) vertices 4..7 take face 3's (-X) UVs (12..15), mirrored in u */
        c.uv[2 * (4 + k)] = c.uv[2 * (12 + (k ^ 1))];
        c.uv[2 * (4 + k) + 1] = c.uv[2 * (12 + k) + 1];
    }
    Bake m; setup(m, c, tex, 64, 64, 64, 128);
    CHECK(run(m) == 0, "mirrored run: %s", m.err.message);
    std::printf("mirrored/overlapping chart: %llu texels covered twice\n", (unsigned long long)m.stats.texels_overlap);
    CHECK(m.stats.texels_overlap > 100, "no overlap counted");
    /* two parts on two outputs with different textures; a part without a texture (factor only) */
    UvMesh t = uv_torus(1.0, 0.45, 32, 16);
    t.transform(0.6, 0, 0, 2.5); /* above the cube, apart from it */
    std::vector<unsigned char> gray(16 * 16 * 3, 200);
    supermat_uv_part parts[3];
    std::memset(parts, 0, sizeof parts);
    parts[0].positions = c.pos.data(); parts[0].uvs = c.uv.data(); parts[0].vertex_count = c.nv();
    parts[0].indices = c.idx.data(); parts[0].index_count = (uint32_t)c.idx.size();
    parts[0].base_color.pixels = tex.data(); parts[0].base_color.width = 64; parts[0].base_color.height = 64; parts[0].base_color.channels = 3;
    parts[1] = parts[0];
    parts[1].positions = t.pos.data(); parts[1].uvs = t.uv.data(); parts[1].vertex_count = t.nv();
    parts[1].indices = t.idx.data(); parts[1].index_count = (uint32_t)t.idx.size();
    parts[1].base_color.pixels = gray.data(); parts[1].base_color.width = 16; parts[1].base_color.height = 16;
    parts[1].output = 1;
    static const float red[4] = {1.0f, 0.0f, 0.0f, 1.0f};
    parts[2] = parts[1];
    parts[2].base_color.pixels = NULL; parts[2].base_color_factor = red;
    parts[2].output = 1;
    supermat_uv_bake_desc d;
    std::memset(&d, 0, sizeof d);
    d.parts = parts; d.part_count = 2; d.output_count = 2; d.texture_width = d.texture_height = 64; d.view_size = 128;
    d.passthrough = 1;
    std::vector<unsigned char> o0(64 * 64 * 4), o1(64 * 64 * 4);
    supermat_uv_output outs[2];
    std::memset(outs, 0, sizeof outs);
    outs[0].base_color.pixels = o0.data(); outs[0].base_color.channels = 4;
    outs[1].base_color.pixels = o1.data(); outs[1].base_color.channels = 4;
    supermat_error err;
    Capture *cap = new Capture;
    d.debug = capture_cb; d.debug_user = cap;
    supermat_result r = supermat_uv_bake(&d, outs, NULL, &err);
    for (int v = 0; v < 6; v++) write_png(g_out + "/two_view_" + std::to_string(v) + ".png", cap->img[SUPERMAT_UV_DEBUG_VIEW][v].data(), 128, 128, 4);
    write_png(g_out + "/two_partial_1.png", cap->img[SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO][1].data(), 64, 64, 3);
    write_png(g_out + "/two_mask_1.png", cap->img[SUPERMAT_UV_DEBUG_MASK][1].data(), 64, 64, 1);
    delete cap;
    d.debug = NULL;
    long g = 0;
    for (int i = 0; i < 64 * 64; i++) g += std::abs(o1[i * 4] - 200) <= 2 && o1[i * 4 + 3] == 255;
    {
        std::vector<float> f(o1.size());
        for (size_t i = 0; i < f.size(); i++) f[i] = o1[i] / 255.0f;
        write_png(g_out + "/two_outputs_1.png", f.data(), 64, 64, 4);
    }
    CHECK(r == 0 && g == 64 * 64, "two outputs: %d (%s), gray texels %ld", r, err.message, g);
    d.part_count = 3; /* the red torus stacked on the gray one: every texel of output 1 is covered twice */
    supermat_uv_stats st;
    r = supermat_uv_bake(&d, outs, &st, &err);
    long stacked = 0;
    for (int i = 0; i < 64 * 64; i++) stacked += (std::abs(o1[i * 4] - 200) <= 2 && o1[i * 4 + 1] > 190) || (o1[i * 4] > 250 && o1[i * 4 + 1] < 5);
    std::printf("stacked parts: %llu texels covered more than once, %ld of 4096 texels gray or red\n", (unsigned long long)st.texels_overlap, stacked);
    CHECK(r == 0 && st.texels_overlap >= 64 * 64 && stacked == 64 * 64, "stacked parts: %d, overlap %llu", r, (unsigned long long)st.texels_overlap);
}

/* ---- 7. the full network path with the tiny random models ------------------------------------ */
static std::vector<unsigned char> read_file(const char *path) {
    std::vector<unsigned char> b;
    FILE *f = std::fopen(path, "rb");
    if (!f) return b;
    std::fseek(f, 0, SEEK_END);
    long n = std::ftell(f);
    std::fseek(f, 0, SEEK_SET);
    b.resize((size_t)n);
    if (std::fread(b.data(), 1, b.size(), f) != b.size()) b.clear();
    std::fclose(f);
    return b;
}

static void test_full(const char *mv_path, const char *uv_path) {
    std::vector<unsigned char> fmv = read_file(mv_path), fuv = read_file(uv_path);
    CHECK(!fmv.empty() && !fuv.empty(), "cannot read %s or %s", mv_path, uv_path);
    if (fmv.empty() || fuv.empty()) return;
    supermat_model *mv = NULL, *uv = NULL;
    supermat_model_desc md;
    supermat_error err;
    std::memset(&md, 0, sizeof md);
    md.data = fmv.data(); md.size = fmv.size();
    CHECK(supermat_model_create(&md, &mv, &err) == 0, "mv model: %s", err.message);
    md.data = fuv.data(); md.size = fuv.size();
    CHECK(supermat_model_create(&md, &uv, &err) == 0, "uv model: %s", err.message);
    if (!mv || !uv) { supermat_model_destroy(mv); supermat_model_destroy(uv); return; }
    UvMesh s = uv_torus(1.0, 0.45, 32, 16);
    std::vector<unsigned char> tex = uv_smooth_texture(64, 64);
    Bake b;
    setup(b, s, tex, 64, 64, 128, 64);
    b.desc.passthrough = 0;
    b.desc.mv_model = mv; b.desc.albedo_refine_model = uv; b.desc.rm_refine_model = uv;
    int calls = 0;
    b.desc.progress = [](void *u, float, const char *) { ++*(int *)u; return 0; };
    b.desc.progress_user = &calls;
    size_t est = 0;
    CHECK(supermat_uv_bake_memory(&b.desc, &est, &err) == 0, "memory: %s", err.message);
    auto t0 = std::chrono::steady_clock::now();
    supermat_result r = run(b);
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CHECK(r == SUPERMAT_SUCCESS, "full path: %s", b.err.message);
    if (!r) {
        dump(b, "full");
        bool have = true;
        for (int v = 0; v < 6; v++) have = have && b.cap.img[SUPERMAT_UV_DEBUG_PRED_ALBEDO][v].size() == 64 * 64 * 3 && b.cap.img[SUPERMAT_UV_DEBUG_PRED_RM][v].size() == 64 * 64 * 3;
        have = have && b.cap.img[SUPERMAT_UV_DEBUG_REFINED_ALBEDO][0].size() == 128 * 128 * 3 && b.cap.img[SUPERMAT_UV_DEBUG_REFINED_RM][0].size() == 128 * 128 * 3;
        CHECK(have, "missing debug images of the network path");
        /* refined values land on the chart texels (refined everywhere on the charts) */
        const std::vector<float> &ref = b.cap.img[SUPERMAT_UV_DEBUG_REFINED_ALBEDO][0], &ch = b.cap.img[SUPERMAT_UV_DEBUG_CHART][0];
        long same = 0, n = 0;
        for (size_t i = 0; i < ch.size(); i++)
            if (ch[i] > 0) {
                n++;
                float v = ref[i * 3]; v = v < 0 ? 0 : v > 1 ? 1 : v;
                same += std::abs((int)b.albedo[i * 3] - (int)(v * 255 + 0.5f)) <= 1;
            }
        CHECK(n > 0 && same == n, "refined albedo not in the output on %ld of %ld chart texels", n - same, n);
        std::printf("full path (tiny models, views 64, texture 128): %.2f s, %d progress calls, memory estimate %.1f MB\n", secs,
                    calls, est / 1e6);
    }
    /* a wrong model kind */
    b.desc.mv_model = uv;
    r = run(b);
    CHECK(r == SUPERMAT_ERROR_UNSUPPORTED, "uv model as mv model: %d", r);
    /* cancellation during the networks */
    b.desc.mv_model = mv;
    calls = 0;
    b.desc.progress = [](void *u, float f, const char *) { return ++*(int *)u > 5 && f > 0.1f ? 1 : 0; };
    r = run(b);
    CHECK(r == SUPERMAT_ERROR_CANCELLED, "cancel in the network: %d %s", r, b.err.message);
    supermat_model_destroy(mv);
    supermat_model_destroy(uv);
}

int main(int argc, char **argv) {
    if (argc > 1) g_out = argv[1];
    if (argc > 3) {
        test_full(argv[2], argv[3]);
    } else {
        test_cameras();
        test_render_vs_embree();
        test_roundtrip();
        test_gutter();
        test_degenerate();
        test_uv_cases();
    }
    std::printf("%d passed, %d failed\n", g_pass, g_fail);
    return g_fail ? 1 : 0;
}
