/* supermat mesh: bake PBR textures for a glTF asset with supermat_uv.h (C++11, tinygltf).
 *
 *   supermat mesh --mv-model F --albedo-refine F --rm-refine F IN.gltf OUT.gltf
 *                 [--passthrough] [--debug-dir DIR] [--size N] [--views-size N] [--threads N]
 *                 [--gutter N] [--edge-reject N] [--weight average|cos] [--supersample N]
 *
 * Reads the first mesh of IN (.gltf or .glb) with its node transform (the first node instancing it),
 * every triangle primitive with its material's baseColor texture (texCoord, sampler wrap, factor),
 * converts glTF's Y-up frame to supermat_uv.h's Z-up one ((x, y, z) -> (x, -z, y)), bakes one pair of
 * textures per material and writes OUT: the same asset whose materials of that mesh point at the new
 * baseColor (sRGB PNG) and metallicRoughness (G roughness, B metallic) textures, with factors 1.
 * --debug-dir writes view_K.png, pred_albedo_K.png, pred_rm_K.png, partial_albedo.png,
 * partial_rm.png, mask.png, position.png (suffix _M for the M-th material after the first).
 *
 * Build: standalone with -DSUPERMAT_MESH_MAIN (which also compiles supermat.h's implementation), or
 * linked into the `supermat` CLI, whose translation unit has SUPERMAT_IMPLEMENTATION, by calling
 * supermat_cli_mesh(). Link -ltinygltf -lstb (Debian's libtinygltf.so uses libstb's stb_image).
 */
#ifdef SUPERMAT_MESH_MAIN
#define SUPERMAT_IMPLEMENTATION
#endif
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"

#include <tiny_gltf.h>
#include <stb/stb_image_write.h>

#include <dirent.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <map>
#include <string>
#include <vector>

extern "C" int supermat_cli_mesh(int argc, char **argv);

namespace {

struct Mat4 {
    double m[16]; /* column-major, as glTF */
    Mat4() { for (int i = 0; i < 16; i++) m[i] = (i % 5 == 0) ? 1.0 : 0.0; }
    Mat4 operator*(const Mat4 &b) const {
        Mat4 r;
        for (int c = 0; c < 4; c++)
            for (int rr = 0; rr < 4; rr++) {
                double s = 0;
                for (int k = 0; k < 4; k++) s += m[k * 4 + rr] * b.m[c * 4 + k];
                r.m[c * 4 + rr] = s;
            }
        return r;
    }
};

Mat4 node_local(const tinygltf::Node &n) {
    Mat4 r;
    if (n.matrix.size() == 16) {
        for (int i = 0; i < 16; i++) r.m[i] = n.matrix[i];
        return r;
    }
    Mat4 t, q, s;
    if (n.translation.size() == 3) { t.m[12] = n.translation[0]; t.m[13] = n.translation[1]; t.m[14] = n.translation[2]; }
    if (n.rotation.size() == 4) {
        double x = n.rotation[0], y = n.rotation[1], z = n.rotation[2], w = n.rotation[3];
        q.m[0] = 1 - 2 * (y * y + z * z); q.m[1] = 2 * (x * y + z * w); q.m[2] = 2 * (x * z - y * w);
        q.m[4] = 2 * (x * y - z * w); q.m[5] = 1 - 2 * (x * x + z * z); q.m[6] = 2 * (y * z + x * w);
        q.m[8] = 2 * (x * z + y * w); q.m[9] = 2 * (y * z - x * w); q.m[10] = 1 - 2 * (x * x + y * y);
    }
    if (n.scale.size() == 3) { s.m[0] = n.scale[0]; s.m[5] = n.scale[1]; s.m[10] = n.scale[2]; }
    return t * q * s;
}

/* the world matrix of the first node (depth first from the scene roots) instancing mesh `mesh` */
bool find_mesh_node(const tinygltf::Model &m, int node, const Mat4 &parent, int mesh, Mat4 *out, int depth) {
    if (node < 0 || node >= (int)m.nodes.size() || depth > 64) return false;
    Mat4 w = parent * node_local(m.nodes[node]);
    if (m.nodes[node].mesh == mesh) { *out = w; return true; }
    for (int c : m.nodes[node].children)
        if (find_mesh_node(m, c, w, mesh, out, depth + 1)) return true;
    return false;
}

/* element i, component k of an accessor as a float (normalised integers mapped to [0,1] / [-1,1]) */
struct AccessorReader {
    const unsigned char *base = nullptr;
    size_t stride = 0, count = 0;
    int comps = 0, type = 0;
    bool normalized = false;
    bool init(const tinygltf::Model &m, int index, std::string *err, const char *what) {
        if (index < 0 || index >= (int)m.accessors.size()) { *err = std::string(what) + ": no such accessor"; return false; }
        const tinygltf::Accessor &a = m.accessors[index];
        if (a.sparse.isSparse) { *err = std::string(what) + ": sparse accessors are not supported"; return false; }
        if (a.bufferView < 0 || a.bufferView >= (int)m.bufferViews.size()) { *err = std::string(what) + ": accessor without a buffer view"; return false; }
        const tinygltf::BufferView &bv = m.bufferViews[a.bufferView];
        if (bv.buffer < 0 || bv.buffer >= (int)m.buffers.size()) { *err = std::string(what) + ": bad buffer"; return false; }
        const tinygltf::Buffer &b = m.buffers[bv.buffer];
        comps = tinygltf::GetNumComponentsInType(a.type);
        int csize = tinygltf::GetComponentSizeInBytes(a.componentType);
        if (comps <= 0 || csize <= 0) { *err = std::string(what) + ": bad accessor type"; return false; }
        type = a.componentType;
        normalized = a.normalized;
        count = a.count;
        stride = a.ByteStride(bv) > 0 ? (size_t)a.ByteStride(bv) : (size_t)comps * csize;
        size_t need = a.byteOffset + bv.byteOffset + (count ? (count - 1) * stride + (size_t)comps * csize : 0);
        if (need > b.data.size()) { *err = std::string(what) + ": accessor runs past its buffer"; return false; }
        base = b.data.data() + bv.byteOffset + a.byteOffset;
        return true;
    }
    double get(size_t i, int k) const {
        const unsigned char *p = base + i * stride;
        switch (type) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, p + 4 * k, 4); return f; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: { double v = p[k]; return normalized ? v / 255.0 : v; }
        case TINYGLTF_COMPONENT_TYPE_BYTE: { double v = (signed char)p[k]; return normalized ? std::fmax(v / 127.0, -1.0) : v; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { unsigned short s; std::memcpy(&s, p + 2 * k, 2); return normalized ? s / 65535.0 : s; }
        case TINYGLTF_COMPONENT_TYPE_SHORT: { short s; std::memcpy(&s, p + 2 * k, 2); return normalized ? std::fmax(s / 32767.0, -1.0) : s; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { unsigned u; std::memcpy(&u, p + 4 * k, 4); return u; }
        default: return 0;
        }
    }
};

supermat_uv_wrap wrap_of(int gl) {
    return gl == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE ? SUPERMAT_UV_WRAP_CLAMP
         : gl == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? SUPERMAT_UV_WRAP_MIRROR : SUPERMAT_UV_WRAP_REPEAT;
}

struct Prim {
    std::vector<float> pos, uv, nrm;
    std::vector<uint32_t> idx;
    std::vector<unsigned char> tex; /* 8-bit */
    int tw = 0, th = 0, tch = 0;
    float factor[4] = {1, 1, 1, 1};
    supermat_uv_wrap wu = SUPERMAT_UV_WRAP_REPEAT, wv = SUPERMAT_UV_WRAP_REPEAT;
    int material = -1, texcoord = 0, sampler = -1, output = 0;
};

std::vector<unsigned char> read_whole(const std::string &path) {
    std::vector<unsigned char> b;
    FILE *f = std::fopen(path.c_str(), "rb");
    if (!f) return b;
    std::fseek(f, 0, SEEK_END);
    long n = std::ftell(f);
    std::fseek(f, 0, SEEK_SET);
    if (n > 0) {
        b.resize((size_t)n);
        if (std::fread(b.data(), 1, b.size(), f) != b.size()) b.clear();
    }
    std::fclose(f);
    return b;
}

std::string dir_of(const std::string &p) {
    size_t s = p.find_last_of('/');
    return s == std::string::npos ? std::string(".") : p.substr(0, s);
}
std::string stem_of(const std::string &p) {
    size_t s = p.find_last_of('/');
    std::string f = s == std::string::npos ? p : p.substr(s + 1);
    size_t d = f.find_last_of('.');
    return d == std::string::npos ? f : f.substr(0, d);
}

bool write_png(const std::string &path, const float *data, int w, int h, int ch) {
    std::vector<unsigned char> b((size_t)w * h * ch);
    for (size_t i = 0; i < b.size(); i++) {
        float v = data[i];
        v = v < 0 ? 0 : v > 1 ? 1 : v;
        b[i] = (unsigned char)(v * 255.0f + 0.5f);
    }
    return stbi_write_png(path.c_str(), w, h, ch, b.data(), w * ch) != 0;
}

struct Debug {
    std::string dir;
    bool failed = false;
};
void debug_cb(void *user, supermat_uv_debug_kind k, int index, const float *data, int w, int h, int c) {
    Debug *d = (Debug *)user;
    const char *name = nullptr;
    bool per_view = false;
    switch (k) {
    case SUPERMAT_UV_DEBUG_VIEW: name = "view"; per_view = true; break;
    case SUPERMAT_UV_DEBUG_PRED_ALBEDO: name = "pred_albedo"; per_view = true; break;
    case SUPERMAT_UV_DEBUG_PRED_RM: name = "pred_rm"; per_view = true; break;
    case SUPERMAT_UV_DEBUG_PARTIAL_ALBEDO: name = "partial_albedo"; break;
    case SUPERMAT_UV_DEBUG_PARTIAL_RM: name = "partial_rm"; break;
    case SUPERMAT_UV_DEBUG_MASK: name = "mask"; break;
    case SUPERMAT_UV_DEBUG_POSITION: name = "position"; break;
    case SUPERMAT_UV_DEBUG_REFINED_ALBEDO: name = "refined_albedo"; break;
    case SUPERMAT_UV_DEBUG_REFINED_RM: name = "refined_rm"; break;
    default: return;
    }
    std::string f = d->dir + "/" + name;
    if (per_view) f += "_" + std::to_string(index);
    else if (index > 0) f += "_" + std::to_string(index);
    if (!write_png(f + ".png", data, w, h, c)) d->failed = true;
}

int progress_cb(void *user, float f, const char *what) {
    int *last = (int *)user;
    int pct = (int)(f * 100);
    if (pct / 5 != *last / 5) { std::fprintf(stderr, "\r%3d%% %-24s", pct, what); *last = pct; }
    return 0;
}

/* A file written in full or not at all: fwrite/fflush/fclose all checked. */
bool write_file(const std::string &path, const void *data, size_t n) {
    FILE *f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    bool ok = (n == 0 || std::fwrite(data, 1, n, f) == n);
    ok = (std::fflush(f) == 0) && ok;
    ok = (std::fclose(f) == 0) && ok;
    return ok;
}
void png_to_vec(void *ctx, void *data, int n) {
    std::vector<unsigned char> *v = (std::vector<unsigned char> *)ctx;
    v->insert(v->end(), (unsigned char *)data, (unsigned char *)data + n);
}

/* writes our new PNGs (their pixels are in Image::image) into the staging folder; keeps every other
   image as it was (copied there when OUT lives in another folder than IN) */
struct Writer {
    std::string in_dir, out_dir, stage;
    std::map<std::string, bool> ours;
    std::string failed; /* the first file that could not be written */
};
bool image_writer(const std::string *, const std::string *filename, const tinygltf::Image *image, bool,
                  std::string *out_uri, void *user) {
    Writer *w = (Writer *)user;
    if (image->uri.compare(0, 5, "data:") == 0) return false;
    if (image->uri.empty()) return false; /* in a buffer view: stays there */
    std::string path = w->stage + "/" + *filename;
    if (w->ours.count(image->uri)) {
        std::vector<unsigned char> png;
        if (!stbi_write_png_to_func(png_to_vec, &png, image->width, image->height, image->component, image->image.data(),
                                    image->width * image->component) || !write_file(path, png.data(), png.size())) {
            if (w->failed.empty()) w->failed = w->out_dir + "/" + *filename;
            return false;
        }
        *out_uri = image->uri;
        return true;
    }
    /* an original image file: copy its bytes when OUT lives elsewhere */
    if (w->in_dir != w->out_dir) {
        std::vector<unsigned char> b = read_whole(w->in_dir + "/" + image->uri);
        if (!write_file(w->stage + "/" + image->uri, b.data(), b.size())) {
            if (w->failed.empty()) w->failed = w->out_dir + "/" + image->uri;
            return false;
        }
    }
    *out_uri = image->uri;
    return true;
}

/* the overwrite policy of the `supermat` CLI (its --force / --skip-existing): 0 refuse, 1 force, 2 skip */
int exists_l(const std::string &p) {
    struct stat st;
    return lstat(p.c_str(), &st) == 0;
}

/* every regular file of the staging folder (relative names, one level of sub-folders) */
void list_files(const std::string &root, const std::string &rel, std::vector<std::string> &out) {
    DIR *d = opendir((root + (rel.empty() ? "" : "/" + rel)).c_str());
    if (!d) return;
    while (struct dirent *e = readdir(d)) {
        std::string n = e->d_name;
        if (n == "." || n == "..") continue;
        std::string r = rel.empty() ? n : rel + "/" + n;
        struct stat st;
        if (lstat((root + "/" + r).c_str(), &st) != 0) continue;
        if (S_ISDIR(st.st_mode)) list_files(root, r, out);
        else out.push_back(r);
    }
    closedir(d);
}
void remove_tree(const std::string &root) {
    std::vector<std::string> files;
    list_files(root, "", files);
    for (const std::string &f : files) std::remove((root + "/" + f).c_str());
    for (size_t k = files.size(); k-- > 0;) { /* sub-folders, deepest first */
        size_t s = files[k].find_last_of('/');
        if (s != std::string::npos) rmdir((root + "/" + files[k].substr(0, s)).c_str());
    }
    rmdir(root.c_str());
}

int usage() {
    std::fprintf(stderr,
                 "usage: supermat mesh --mv-model F --albedo-refine F --rm-refine F IN.gltf OUT.gltf\n"
                 "       [--passthrough] [--debug-dir DIR] [--size N] [--views-size N] [--threads N]\n"
                 "       [--gutter N] [--edge-reject N] [--weight average|cos] [--supersample N]\n"
                 "  --passthrough   no networks: albedo = the rendered base colour, roughness 0.5, metallic 0\n"
                 "  --force / --skip-existing   replace / keep existing output files (default: refuse them)\n"
                 "  --size N        output texture size (default 1024); --views-size N: rendered views (512)\n");
    return 2;
}

bool load_model(const char *path, std::vector<unsigned char> &bytes, supermat_model **m) {
    bytes = read_whole(path);
    if (bytes.empty()) { std::fprintf(stderr, "supermat mesh: cannot read %s\n", path); return false; }
    supermat_model_desc md;
    std::memset(&md, 0, sizeof md);
    md.data = bytes.data(); md.size = bytes.size();
    md.copy_data = 1; /* the model keeps what it needs: the file bytes go now */
    supermat_error err;
    supermat_result r = supermat_model_create(&md, m, &err);
    std::vector<unsigned char>().swap(bytes);
    if (r != SUPERMAT_SUCCESS) {
        std::fprintf(stderr, "supermat mesh: %s: %s\n", path, err.message);
        return false;
    }
    return true;
}

} // namespace

extern "C" int supermat_cli_mesh(int argc, char **argv) {
    const char *mv_path = nullptr, *bc_path = nullptr, *rm_path = nullptr, *in = nullptr, *out = nullptr, *dbg = nullptr;
    int passthrough = 0, size = 1024, views = 512, threads = 0, gutter = 0, edge_reject = 0, supersample = 0, policy = 0;
    supermat_uv_weight weight = SUPERMAT_UV_WEIGHT_AVERAGE;
    for (int i = 1; i < argc; i++) {
        std::string a = argv[i];
        bool more = i + 1 < argc;
        if (a == "--mv-model" && more) mv_path = argv[++i];
        else if (a == "--albedo-refine" && more) bc_path = argv[++i];
        else if (a == "--rm-refine" && more) rm_path = argv[++i];
        else if (a == "--debug-dir" && more) dbg = argv[++i];
        else if (a == "--size" && more) size = std::atoi(argv[++i]);
        else if (a == "--views-size" && more) views = std::atoi(argv[++i]);
        else if (a == "--threads" && more) threads = std::atoi(argv[++i]);
        else if (a == "--gutter" && more) gutter = std::atoi(argv[++i]);
        else if (a == "--edge-reject" && more) edge_reject = std::atoi(argv[++i]);
        else if (a == "--supersample" && more) supersample = std::atoi(argv[++i]);
        else if (a == "--weight" && more) {
            std::string w = argv[++i];
            if (w == "cos") weight = SUPERMAT_UV_WEIGHT_COS_POWER;
            else if (w != "average") return usage();
        } else if (a == "--passthrough") passthrough = 1;
        else if (a == "--force" || a == "--skip-existing") {
            int want = a == "--force" ? 1 : 2;
            if (policy && policy != want) { std::fprintf(stderr, "supermat mesh: --force and --skip-existing exclude each other\n"); return 2; }
            policy = want;
        }
        else if (a == "-h" || a == "--help") return usage();
        else if (a.size() > 1 && a[0] == '-' && a != "-") { std::fprintf(stderr, "supermat mesh: unknown option %s\n", a.c_str()); return usage(); }
        else if (!in) in = argv[i];
        else if (!out) out = argv[i];
        else return usage();
    }
    if (!in || !out) return usage();
    if (exists_l(out) && policy != 1) { /* before any work */
        if (policy == 2) { std::fprintf(stderr, "kept '%s' (it exists; --skip-existing)\n", out); return 0; }
        std::fprintf(stderr, "supermat mesh: '%s' exists and was not written by this run: --force replaces it, --skip-existing keeps it\n", out);
        return 1;
    }
    if (!passthrough && (!mv_path || !bc_path || !rm_path)) {
        std::fprintf(stderr, "supermat mesh: give --mv-model, --albedo-refine and --rm-refine (or --passthrough)\n");
        return 2;
    }
    auto t0 = std::chrono::steady_clock::now();

    /* ---- read the glTF ---- */
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string err, warn, inpath = in, outpath = out;
    bool glb_in = inpath.size() > 4 && inpath.compare(inpath.size() - 4, 4, ".glb") == 0;
    bool ok = glb_in ? loader.LoadBinaryFromFile(&model, &err, &warn, inpath) : loader.LoadASCIIFromFile(&model, &err, &warn, inpath);
    if (!warn.empty()) std::fprintf(stderr, "supermat mesh: %s\n", warn.c_str());
    if (!ok) { std::fprintf(stderr, "supermat mesh: cannot read %s: %s\n", in, err.c_str()); return 1; }
    if (model.meshes.empty()) { std::fprintf(stderr, "supermat mesh: %s has no mesh\n", in); return 1; }
    Mat4 world;
    {
        bool found = false;
        int scene = model.defaultScene >= 0 && model.defaultScene < (int)model.scenes.size() ? model.defaultScene : 0;
        if (scene < (int)model.scenes.size())
            for (int r : model.scenes[scene].nodes)
                if ((found = find_mesh_node(model, r, Mat4(), 0, &world, 0))) break;
        for (int n = 0; !found && n < (int)model.nodes.size(); n++) /* not in the scene: its own transform */
            if (model.nodes[n].mesh == 0) { world = node_local(model.nodes[n]); found = true; }
    }
    /* normals: the inverse transpose of the 3x3 part (cofactor matrix, up to a positive scale) */
    double A[9], Nm[9];
    for (int c = 0; c < 3; c++) for (int r = 0; r < 3; r++) A[r * 3 + c] = world.m[c * 4 + r];
    Nm[0] = A[4] * A[8] - A[5] * A[7]; Nm[1] = A[5] * A[6] - A[3] * A[8]; Nm[2] = A[3] * A[7] - A[4] * A[6];
    Nm[3] = A[2] * A[7] - A[1] * A[8]; Nm[4] = A[0] * A[8] - A[2] * A[6]; Nm[5] = A[1] * A[6] - A[0] * A[7];
    Nm[6] = A[1] * A[5] - A[2] * A[4]; Nm[7] = A[2] * A[3] - A[0] * A[5]; Nm[8] = A[0] * A[4] - A[1] * A[3];
    double det = A[0] * Nm[0] + A[1] * Nm[1] + A[2] * Nm[2];
    if (det < 0) for (double &v : Nm) v = -v;

    std::vector<Prim> prims;
    std::map<int, int> outputs; /* material -> output */
    std::vector<int> output_material;
    const tinygltf::Mesh &mesh = model.meshes[0];
    for (size_t pi = 0; pi < mesh.primitives.size(); pi++) {
        const tinygltf::Primitive &p = mesh.primitives[pi];
        if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1) {
            std::fprintf(stderr, "supermat mesh: primitive %zu is not a triangle list (mode %d): skipped\n", pi, p.mode);
            continue;
        }
        Prim q;
        q.material = p.material;
        if (p.material >= 0 && p.material < (int)model.materials.size()) {
            const tinygltf::PbrMetallicRoughness &pbr = model.materials[p.material].pbrMetallicRoughness;
            for (int k = 0; k < 4 && k < (int)pbr.baseColorFactor.size(); k++) q.factor[k] = (float)pbr.baseColorFactor[k];
            int ti = pbr.baseColorTexture.index;
            q.texcoord = pbr.baseColorTexture.texCoord;
            if (ti >= 0 && ti < (int)model.textures.size()) {
                const tinygltf::Texture &t = model.textures[ti];
                q.sampler = t.sampler;
                if (t.sampler >= 0 && t.sampler < (int)model.samplers.size()) {
                    q.wu = wrap_of(model.samplers[t.sampler].wrapS);
                    q.wv = wrap_of(model.samplers[t.sampler].wrapT);
                }
                if (t.source >= 0 && t.source < (int)model.images.size() && !model.images[t.source].image.empty()) {
                    const tinygltf::Image &im = model.images[t.source];
                    q.tw = im.width; q.th = im.height; q.tch = im.component;
                    size_t n = (size_t)im.width * im.height * im.component;
                    q.tex.resize(n);
                    if (im.bits == 16)
                        for (size_t i = 0; i < n; i++) { unsigned short s; std::memcpy(&s, &im.image[2 * i], 2); q.tex[i] = (unsigned char)((s + 128) / 257); }
                    else if (im.image.size() >= n) std::memcpy(q.tex.data(), im.image.data(), n);
                    else q.tex.clear();
                } else std::fprintf(stderr, "supermat mesh: the base colour image of material %d could not be read: using its factor\n", p.material);
            }
        }
        std::string attr = "TEXCOORD_" + std::to_string(q.texcoord);
        auto pa = p.attributes.find("POSITION"), ta = p.attributes.find(attr), na = p.attributes.find("NORMAL");
        if (pa == p.attributes.end()) { std::fprintf(stderr, "supermat mesh: primitive %zu has no POSITION\n", pi); return 1; }
        if (ta == p.attributes.end()) {
            std::fprintf(stderr, "supermat mesh: primitive %zu has no %s: the mesh needs UVs (unwrap it first)\n", pi, attr.c_str());
            return 1;
        }
        AccessorReader P, T, N;
        if (!P.init(model, pa->second, &err, "POSITION") || !T.init(model, ta->second, &err, attr.c_str()) ||
            (na != p.attributes.end() && !N.init(model, na->second, &err, "NORMAL"))) {
            std::fprintf(stderr, "supermat mesh: primitive %zu: %s\n", pi, err.c_str());
            return 1;
        }
        if (P.comps != 3 || T.comps != 2 || T.count != P.count || (N.base && (N.comps != 3 || N.count != P.count))) {
            std::fprintf(stderr, "supermat mesh: primitive %zu: attribute shapes do not match\n", pi);
            return 1;
        }
        for (size_t v = 0; v < P.count; v++) {
            double x = P.get(v, 0), y = P.get(v, 1), z = P.get(v, 2), w[3];
            for (int r = 0; r < 3; r++) w[r] = world.m[r] * x + world.m[4 + r] * y + world.m[8 + r] * z + world.m[12 + r];
            q.pos.push_back((float)w[0]); q.pos.push_back((float)-w[2]); q.pos.push_back((float)w[1]); /* Y up -> Z up */
            q.uv.push_back((float)T.get(v, 0)); q.uv.push_back((float)T.get(v, 1));
            if (N.base) {
                double a = N.get(v, 0), b = N.get(v, 1), c = N.get(v, 2), n[3];
                for (int r = 0; r < 3; r++) n[r] = Nm[r * 3] * a + Nm[r * 3 + 1] * b + Nm[r * 3 + 2] * c;
                q.nrm.push_back((float)n[0]); q.nrm.push_back((float)-n[2]); q.nrm.push_back((float)n[1]);
            }
        }
        if (p.indices >= 0) {
            AccessorReader I;
            if (!I.init(model, p.indices, &err, "indices") || I.comps != 1) { std::fprintf(stderr, "supermat mesh: primitive %zu: %s\n", pi, err.c_str()); return 1; }
            for (size_t k = 0; k < I.count; k++) q.idx.push_back((uint32_t)I.get(k, 0));
        } else
            for (size_t k = 0; k < P.count; k++) q.idx.push_back((uint32_t)k);
        if (det < 0) /* a mirroring transform: keep the winding consistent with the normals */
            for (size_t k = 0; k + 2 < q.idx.size(); k += 3) std::swap(q.idx[k + 1], q.idx[k + 2]);
        if (!outputs.count(q.material)) { outputs[q.material] = (int)output_material.size(); output_material.push_back(q.material); }
        q.output = outputs[q.material];
        prims.push_back(std::move(q));
    }
    if (prims.empty()) { std::fprintf(stderr, "supermat mesh: the first mesh has no triangle primitive\n"); return 1; }

    /* ---- models ---- */
    std::vector<unsigned char> fmv, fbc, frm;
    supermat_model *mv = nullptr, *bc = nullptr, *rm = nullptr;
    if (!passthrough) {
        bool same = std::string(bc_path) == rm_path; /* one model serves both when given the same file */
        if (!load_model(mv_path, fmv, &mv) || !load_model(bc_path, fbc, &bc) || (!same && !load_model(rm_path, frm, &rm))) {
            supermat_model_destroy(mv); supermat_model_destroy(bc); supermat_model_destroy(rm);
            return 1;
        }
    }

    /* ---- bake ---- */
    std::vector<supermat_uv_part> parts(prims.size());
    for (size_t i = 0; i < prims.size(); i++) {
        Prim &q = prims[i];
        supermat_uv_part &p = parts[i];
        std::memset(&p, 0, sizeof p);
        p.positions = q.pos.data(); p.uvs = q.uv.data(); p.normals = q.nrm.empty() ? nullptr : q.nrm.data();
        p.vertex_count = (uint32_t)(q.pos.size() / 3);
        p.indices = q.idx.data(); p.index_count = (uint32_t)q.idx.size();
        if (!q.tex.empty()) {
            p.base_color.pixels = q.tex.data(); p.base_color.width = q.tw; p.base_color.height = q.th; p.base_color.channels = q.tch;
        }
        p.base_color_factor = q.factor;
        p.wrap_u = q.wu; p.wrap_v = q.wv;
        p.output = q.output;
    }
    int nout = (int)output_material.size();
    std::vector<std::vector<unsigned char>> albedo(nout), mr(nout);
    std::vector<supermat_uv_output> outs(nout);
    for (int o = 0; o < nout; o++) {
        albedo[o].resize((size_t)size * size * 3);
        mr[o].resize((size_t)size * size * 3);
        std::memset(&outs[o], 0, sizeof outs[o]);
        outs[o].base_color.pixels = albedo[o].data(); outs[o].base_color.channels = 3;
        outs[o].metallic_roughness.pixels = mr[o].data(); outs[o].metallic_roughness.channels = 3;
    }
    supermat_uv_bake_desc bd;
    std::memset(&bd, 0, sizeof bd);
    bd.parts = parts.data(); bd.part_count = (int)parts.size(); bd.output_count = nout;
    bd.texture_width = bd.texture_height = size;
    bd.view_size = views;
    bd.supersample = supersample;
    bd.passthrough = passthrough;
    bd.mv_model = mv; bd.albedo_refine_model = bc; bd.rm_refine_model = rm ? rm : bc;
    bd.weight = weight;
    bd.gutter = gutter;
    bd.edge_reject = edge_reject;
    bd.threads = threads;
    int last = -5;
    if (isatty(2)) { bd.progress = progress_cb; bd.progress_user = &last; }
    Debug dd;
    if (dbg) {
        mkdir(dbg, 0777);
        dd.dir = dbg;
        bd.debug = debug_cb; bd.debug_user = &dd;
    }
    supermat_uv_stats st;
    supermat_error serr;
    supermat_result r = supermat_uv_bake(&bd, outs.data(), &st, &serr);
    if (bd.progress) std::fprintf(stderr, "\r%-40s\r", "");
    supermat_model_destroy(mv); supermat_model_destroy(bc); supermat_model_destroy(rm);
    if (r != SUPERMAT_SUCCESS) {
        std::fprintf(stderr, "supermat mesh: %s (%s)\n", serr.message, supermat_result_string(r));
        return 1;
    }
    if (dd.failed) std::fprintf(stderr, "supermat mesh: could not write every debug image to %s\n", dbg);

    /* ---- write OUT: new images, textures and materials ---- */
    Writer wr;
    wr.in_dir = dir_of(inpath); wr.out_dir = dir_of(outpath);
    std::string stem = stem_of(outpath);
    for (int o = 0; o < nout; o++) {
        int matidx = output_material[o];
        if (matidx < 0) { /* a primitive without material: give it one */
            tinygltf::Material nm;
            nm.name = "supermat";
            model.materials.push_back(nm);
            matidx = (int)model.materials.size() - 1;
            for (size_t i = 0; i < mesh.primitives.size(); i++)
                if (model.meshes[0].primitives[i].material < 0) model.meshes[0].primitives[i].material = matidx;
        }
        int sampler = -1, texcoord = 0;
        for (const Prim &q : prims) if (q.output == o) { sampler = q.sampler; texcoord = q.texcoord; }
        int tex_index[2];
        for (int k = 0; k < 2; k++) {
            tinygltf::Image im;
            im.uri = stem + (k ? "_metallicRoughness" : "_baseColor") + (nout > 1 ? "_" + std::to_string(o) : std::string()) + ".png";
            im.mimeType = "image/png";
            im.width = size; im.height = size; im.component = 3; im.bits = 8;
            im.pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
            im.image = k ? mr[o] : albedo[o];
            wr.ours[im.uri] = true;
            model.images.push_back(im);
            tinygltf::Texture t;
            t.source = (int)model.images.size() - 1;
            t.sampler = sampler;
            model.textures.push_back(t);
            tex_index[k] = (int)model.textures.size() - 1;
        }
        tinygltf::PbrMetallicRoughness &pbr = model.materials[matidx].pbrMetallicRoughness;
        double alpha = pbr.baseColorFactor.size() == 4 ? pbr.baseColorFactor[3] : 1.0;
        pbr.baseColorFactor = {1.0, 1.0, 1.0, alpha}; /* the factor is baked into the texture */
        pbr.baseColorTexture.index = tex_index[0]; pbr.baseColorTexture.texCoord = texcoord;
        pbr.metallicRoughnessTexture.index = tex_index[1]; pbr.metallicRoughnessTexture.texCoord = texcoord;
        pbr.metallicFactor = 1.0; pbr.roughnessFactor = 1.0;
    }
    /* Everything is written into a staging folder beside OUT, read back (a truncated file -- full disk,
       size limit -- does not parse), then moved into place: OUT and its files appear complete or not at
       all. tinygltf does not check its own writes, hence the read-back. */
    tinygltf::TinyGLTF writer;
    writer.SetImageWriter(image_writer, &wr);
    bool glb_out = outpath.size() > 4 && outpath.compare(outpath.size() - 4, 4, ".glb") == 0;
    std::string base = outpath.substr(outpath.find_last_of('/') == std::string::npos ? 0 : outpath.find_last_of('/') + 1);
    wr.stage = wr.out_dir + "/.supermat-mesh-" + std::to_string((long)getpid()) + ".tmp";
    remove_tree(wr.stage);
    if (mkdir(wr.stage.c_str(), 0777) != 0) {
        std::fprintf(stderr, "supermat mesh: cannot write into %s: %s\n", wr.out_dir.c_str(), std::strerror(errno));
        return 1;
    }
    for (const tinygltf::Image &im : model.images) /* sub-folders of image URIs, in the stage too */
        for (size_t s = im.uri.find('/'); s != std::string::npos && im.uri.compare(0, 5, "data:") != 0; s = im.uri.find('/', s + 1))
            mkdir((wr.stage + "/" + im.uri.substr(0, s)).c_str(), 0777);
    std::string staged = wr.stage + "/" + base;
    bool wok = writer.WriteGltfSceneToFile(&model, staged, false, false, true, glb_out) && wr.failed.empty();
    if (wok) {
        tinygltf::Model back;
        std::string e, w;
        tinygltf::TinyGLTF reader;
        wok = glb_out ? reader.LoadBinaryFromFile(&back, &e, &w, staged) : reader.LoadASCIIFromFile(&back, &e, &w, staged);
        for (size_t b = 0; wok && b < back.buffers.size() && b < model.buffers.size(); b++)
            wok = back.buffers[b].data.size() == model.buffers[b].data.size();
        if (!wok && wr.failed.empty()) wr.failed = std::string(out) + " (or its .bin): the written file does not read back complete (disk full?)";
    }
    std::vector<std::string> files;
    if (wok) list_files(wr.stage, "", files);
    for (const std::string &f : files) /* the policy for every file: OUT itself was checked before the work */
        if (f != base && exists_l(wr.out_dir + "/" + f) && policy != 1 &&
            read_whole(wr.out_dir + "/" + f) != read_whole(wr.stage + "/" + f)) { /* the same bytes: nothing lost */
            if (policy == 2) continue;
            std::fprintf(stderr, "supermat mesh: '%s/%s' exists and was not written by this run: --force replaces it, --skip-existing keeps it\n",
                         wr.out_dir.c_str(), f.c_str());
            wok = false;
            wr.failed = "-";
            break;
        }
    for (size_t k = 0; wok && k < files.size(); k++) {
        const std::string &f = files[k];
        std::string dst = wr.out_dir + "/" + f;
        if (f != base && policy == 2 && exists_l(dst)) continue;
        size_t s = f.find_last_of('/');
        if (s != std::string::npos) mkdir((wr.out_dir + "/" + f.substr(0, s)).c_str(), 0777);
        if (std::rename((wr.stage + "/" + f).c_str(), dst.c_str()) != 0) { wr.failed = dst + ": " + std::strerror(errno); wok = false; }
    }
    remove_tree(wr.stage);
    if (!wok) {
        if (wr.failed != "-") std::fprintf(stderr, "supermat mesh: cannot write %s\n", wr.failed.empty() ? out : wr.failed.c_str());
        return 1;
    }
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    std::printf("%s: %d material(s), %u triangles (%u zero-area skipped), %llu chart texels, %.1f%% seen by a view; "
                "%.1f s, peak memory %.0f MB\n",
                out, nout, st.triangles, st.triangles_degenerate, (unsigned long long)st.texels_chart,
                st.texels_chart ? 100.0 * st.texels_seen / st.texels_chart : 0.0, secs, ru.ru_maxrss / 1024.0);
    return 0;
}

#ifdef SUPERMAT_MESH_MAIN
int main(int argc, char **argv) { return supermat_cli_mesh(argc, argv); }
#endif
