/* supermat mesh: bake PBR textures for a glTF asset with supermat_uv.h (C++11, tinygltf).
 *
 *   supermat mesh [--model official | --mv-model F] [--refine | --albedo-refine F | --rm-refine F | --no-refine] IN.gltf OUT.gltf
 *                 [--passthrough] [--keep-observed] [--debug-dir DIR] [--texture-size N] [--views-size N] [--threads N]
 *                 [--gutter N] [--edge-reject N] [--view-weight average|cos] [--supersample N] [--detail F|off] [--detail-limit R|off]
 *
 * Reads IN (.gltf or .glb) and bakes every mesh its default scene shows (each at the world transform of
 * the first node instancing it; glTF's Y-up frame becomes supermat_uv.h's Z-up one, (x, y, z) -> (x, -z, y)):
 * every triangle primitive with its material's baseColor (factor, texture, sampler wrap, texCoord and
 * KHR_texture_transform, which the new textures keep). One pair of textures per material: baseColor (sRGB
 * PNG, with the source texture's alpha when alphaMode is MASK or BLEND) and metallicRoughness (G roughness,
 * B metallic), factors 1. A material that a primitive left unbaked (points, lines, a mesh outside the
 * scene) also uses is baked into a copy. A texture slot only that material used is reused, so that a re-run
 * on its own output keeps the same images. OUT keeps every other property as it is. A .glb OUT holds
 * everything in its binary chunk; a .gltf OUT keeps embedded images embedded (and all of it embedded when
 * IN was), copies referenced files beside it (sub-folders and %-encoded names as they were; files outside
 * IN's folder, read only with --allow-outside-refs, renamed) and names buffers OUT.bin. asset.generator
 * says supermat. Files are read and written through smio.h (docs/security.md): references stay inside
 * IN's folder and are regular files; OUT commits as a whole (a --force re-run gives side files whose
 * bytes changed a fresh name, NAME-1.ext, renames the .gltf last, then removes the old ones).
 * --debug-dir writes view_K.png, pred_albedo_K.png, pred_rm_K.png, partial_albedo.png,
 * partial_rm.png, mask.png, position.png (suffix _M for the M-th material after the first).
 *
 * Build: standalone with -DSUPERMAT_MESH_MAIN (which also compiles supermat.h's implementation), or
 * linked into the `supermat` CLI, whose translation unit has SUPERMAT_IMPLEMENTATION, by calling
 * supermat_cli_mesh_global() (supermat_cli_mesh() parses the output options itself). Link -ltinygltf -lstb (Debian's libtinygltf.so uses libstb's stb_image).
 */
#ifdef SUPERMAT_MESH_MAIN
#define SUPERMAT_IMPLEMENTATION
#endif
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"

#include <tiny_gltf.h>
#include <nlohmann/json.hpp> /* what a replaced .gltf refers to (Debian's nlohmann-json3-dev; CMake checks for it) */
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>
#include "opt_table.h" /* the option table: parsing and --help */
#include "picture_check.h"
#include "smio.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <algorithm>
#include <map>
#include <new>
#include <string>
#include <vector>

extern "C" int supermat_cli_mesh(int argc, char **argv);
extern "C" int supermat_cli_mesh_global(int argc, char **argv, int policy, int allow_outside);
extern "C" void supermat_cli_mesh_keep_models(int keep);
struct supermat_cli_mesh_opts;
extern "C" const cli_optdef supermat_cli_mesh_bake_options[];
extern "C" supermat_cli_mesh_opts *supermat_cli_mesh_opts_new(void);
extern "C" int supermat_cli_mesh_opt_set(supermat_cli_mesh_opts *o, int id, const char *value);
extern "C" int supermat_cli_mesh_opts_check(const supermat_cli_mesh_opts *o);
extern "C" int supermat_cli_mesh_opts_parse(int argc, char **argv, supermat_cli_mesh_opts **opts);
extern "C" int supermat_cli_mesh_run(const supermat_cli_mesh_opts *opts, const char *in, const char *out, int force, int allow_outside);
extern "C" void supermat_cli_mesh_opts_free(supermat_cli_mesh_opts *opts);

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
        /* inside the buffer, without overflow for any count, offset or stride */
        size_t size = b.data.size(), elem = (size_t)comps * (size_t)csize;
        if (a.byteOffset > size || bv.byteOffset > size - a.byteOffset) { *err = std::string(what) + ": accessor starts past its buffer"; return false; }
        size_t avail = size - a.byteOffset - bv.byteOffset;
        if (count && (elem > avail || count - 1 > (avail - elem) / stride)) { *err = std::string(what) + ": accessor runs past its buffer"; return false; }
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
    int material = -1, output = 0;
};

/* what one baked material needs: its base colour (factor, texture pixels, sampler, UV set and
   KHR_texture_transform) and whether its alpha is kept */
struct MatIn {
    int material = -1;                   /* in the output model (a clone when the original is shared) */
    float factor[4] = {1, 1, 1, 1};
    std::vector<unsigned char> tex;      /* 8-bit, tw x th x tch; empty = the factor alone */
    int tw = 0, th = 0, tch = 0;
    supermat_uv_wrap wu = SUPERMAT_UV_WRAP_REPEAT, wv = SUPERMAT_UV_WRAP_REPEAT;
    int sampler = -1, texcoord = 0;
    bool has_xf = false;                 /* KHR_texture_transform on the base colour */
    double xf[6] = {1, 0, 0, 0, 1, 0};   /* u' = xf0 u + xf1 v + xf2, v' = xf3 u + xf4 v + xf5 */
    tinygltf::Value xf_ext;              /* the extension object, put on the new textures too */
    bool alpha = false;                  /* MASK / BLEND with an alpha channel: kept in the baked texture */
};

/* KHR_texture_transform of a textureInfo: false when absent; *err when malformed */
bool texture_transform(const tinygltf::ExtensionMap &ext, MatIn *m, std::string *err) {
    auto it = ext.find("KHR_texture_transform");
    if (it == ext.end()) return false;
    const tinygltf::Value &v = it->second;
    if (!v.IsObject()) { *err = "KHR_texture_transform is not an object"; return false; }
    double off[2] = {0, 0}, sc[2] = {1, 1}, rot = 0;
    for (int k = 0; k < 2; k++) {
        const char *name = k ? "scale" : "offset";
        if (!v.Has(name)) continue;
        const tinygltf::Value &a = v.Get(name);
        if (!a.IsArray() || a.ArrayLen() != 2 || !a.Get(0).IsNumber() || !a.Get(1).IsNumber()) {
            *err = std::string("KHR_texture_transform.") + name + " is not two numbers";
            return false;
        }
        double *d = k ? sc : off;
        d[0] = a.Get(0).GetNumberAsDouble(); d[1] = a.Get(1).GetNumberAsDouble();
    }
    if (v.Has("rotation")) {
        if (!v.Get("rotation").IsNumber()) { *err = "KHR_texture_transform.rotation is not a number"; return false; }
        rot = v.Get("rotation").GetNumberAsDouble();
    }
    if (v.Has("texCoord")) {
        if (!v.Get("texCoord").IsInt() || v.Get("texCoord").GetNumberAsInt() < 0) { *err = "KHR_texture_transform.texCoord is not a set index"; return false; }
        m->texcoord = v.Get("texCoord").GetNumberAsInt();
    }
    /* the extension's matrix T * R * S: R = [cos sin; -sin cos] */
    double c = std::cos(rot), s = std::sin(rot);
    double xf[6] = {c * sc[0], s * sc[1], off[0], -s * sc[0], c * sc[1], off[1]};
    for (double d : xf)
        if (!std::isfinite(d)) { *err = "KHR_texture_transform is not finite"; return false; }
    std::memcpy(m->xf, xf, sizeof xf);
    m->xf_ext = v;
    return true;
}

/* the texture indices a material's extensions name ({"...Texture": {"index": N}} at any depth) */
void extension_textures(const tinygltf::Value &v, std::vector<int> &out) {
    if (v.IsObject()) {
        for (const std::string &k : v.Keys()) {
            const tinygltf::Value &c = v.Get(k);
            if (k.size() >= 7 && k.compare(k.size() - 7, 7, "Texture") == 0 && c.IsObject() && c.Has("index") && c.Get("index").IsInt())
                out.push_back(c.Get("index").GetNumberAsInt());
            extension_textures(c, out);
        }
    } else if (v.IsArray())
        for (size_t i = 0; i < v.ArrayLen(); i++) extension_textures(v.Get((int)i), out);
}
/* every texture index a material refers to, standard slots and extensions */
std::vector<int> material_textures(const tinygltf::Material &m) {
    std::vector<int> t = {m.pbrMetallicRoughness.baseColorTexture.index, m.pbrMetallicRoughness.metallicRoughnessTexture.index,
                          m.normalTexture.index, m.occlusionTexture.index, m.emissiveTexture.index};
    for (const auto &e : m.extensions) extension_textures(e.second, t);
    return t;
}

/* the image indices a texture refers to: source and extension sources (EXT_texture_webp, KHR_texture_basisu) */
std::vector<int> texture_images(const tinygltf::Texture &t) {
    std::vector<int> s = {t.source};
    for (const auto &e : t.extensions)
        if (e.second.IsObject() && e.second.Has("source") && e.second.Get("source").IsInt()) s.push_back(e.second.Get("source").GetNumberAsInt());
    return s;
}

/* bilinear sample of channel ch of an 8-bit texture at texel coordinates (x, y) (centres at +0.5), wrapped */
int wrap_coord(int i, int n, supermat_uv_wrap w) {
    if (w == SUPERMAT_UV_WRAP_CLAMP) return i < 0 ? 0 : i >= n ? n - 1 : i;
    if (w == SUPERMAT_UV_WRAP_MIRROR) {
        int p = ((i % (2 * n)) + 2 * n) % (2 * n);
        return p < n ? p : 2 * n - 1 - p;
    }
    return ((i % n) + n) % n;
}
float sample_channel(const MatIn &m, double x, double y, int ch) {
    x -= 0.5; y -= 0.5;
    double fx = std::floor(x), fy = std::floor(y);
    if (!(std::fabs(fx) < 1e9 && std::fabs(fy) < 1e9)) return 1.0f;
    int x0 = (int)fx, y0 = (int)fy;
    double ax = x - fx, ay = y - fy, r = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int xx = wrap_coord(x0 + i, m.tw, m.wu), yy = wrap_coord(y0 + j, m.th, m.wv);
            r += (i ? ax : 1 - ax) * (j ? ay : 1 - ay) * m.tex[((size_t)yy * m.tw + xx) * m.tch + ch];
        }
    return (float)(r / 255.0);
}

/* a whole regular file (smio.h: a FIFO or a device is refused without blocking; with nofollow a link too);
   empty when it cannot be read, *why says why */
std::vector<unsigned char> read_whole(const std::string &path, bool nofollow = false, std::string *why = nullptr) {
    std::vector<unsigned char> b;
    char msg[256];
    struct stat st;
    int fd = smio_open_regular(path.c_str(), nofollow ? 1 : 0, msg, sizeof msg);
    if (fd < 0) { if (why) *why = msg; return b; }
    if (fstat(fd, &st) == 0 && st.st_size > 0) {
        b.resize((size_t)st.st_size);
        if (smio_read_all(fd, b.data(), b.size()) != 0) { b.clear(); if (why) *why = errno ? std::strerror(errno) : "the file got shorter while reading"; }
    } else if (why)
        *why = "empty file";
    close(fd);
    return b;
}

/* Every file a glTF refers to goes through these callbacks (tinygltf opens nothing itself, and never
   searches the current folder): the reference must be a relative path (smio_ref_syntax) that, every
   symbolic link resolved, stays inside the asset's folder (unless --allow-outside-refs), and a regular file.
   A refused reference is named in `refused`, and the run fails. Writes go through the caller, never here. */
struct RefFs {
    std::string base;      /* the folder tinygltf joins references to (the asset's, as given) */
    std::string real_dir;  /* the same, resolved */
    bool allow_outside = false;
    std::vector<std::string> refused;
    void refuse(const std::string &uri, const std::string &why) {
        std::string m = "'" + uri + "' " + why;
        for (const std::string &r : refused) if (r == m) return;
        refused.push_back(m);
    }
    /* the resolved path of a reference tinygltf asks for, or "" (refused or missing) */
    std::string resolve(const std::string &abs) {
        std::string prefix = base + (base.empty() || base.back() == '/' ? "" : "/");
        if (abs.compare(0, prefix.size(), prefix) != 0) return ""; /* not below the asset's folder: never searched */
        std::string uri = abs.substr(prefix.size());
        if (const char *why = smio_ref_syntax(uri.c_str())) { refuse(uri, why); return ""; }
        char *r = nullptr;
        int in = smio_inside(real_dir.c_str(), abs.c_str(), &r);
        if (in < 0) return ""; /* missing: tinygltf says so */
        std::string resolved = r;
        std::free(r);
        if (!in && !allow_outside) {
            refuse(uri, "leads outside the asset's folder '" + real_dir + "' (through '..' or a symbolic link): refused (--allow-outside-refs reads it)");
            return "";
        }
        struct stat st;
        std::memset(&st, 0, sizeof st);
        if (::stat(resolved.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) { refuse(uri, std::string("is ") + smio_kind(st.st_mode) + ", not a regular file: refused"); return ""; }
        if (st.st_nlink > 1 && !allow_outside) { /* a hard link may be a file from anywhere on the disk */
            refuse(uri, "is a file with " + std::to_string((unsigned long)st.st_nlink) + " hard links (it may be a file from outside the asset): refused (--allow-outside-refs reads it)");
            return "";
        }
        return resolved;
    }
};
bool fs_exists(const std::string &abs, void *user) { return !((RefFs *)user)->resolve(abs).empty(); }
std::string fs_expand(const std::string &path, void *) { return path; } /* no ~ or $VAR expansion */
bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &abs, void *user) {
    std::string r = ((RefFs *)user)->resolve(abs), why;
    if (r.empty()) { if (err) *err = "refused"; return false; }
    *out = read_whole(r, true, &why);
    if (out->empty() && err) *err = why;
    return !out->empty();
}
bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *) {
    if (err) *err = "supermat writes files itself";
    return false;
}
tinygltf::FsCallbacks ref_fs(RefFs *r) {
    tinygltf::FsCallbacks fs;
    fs.FileExists = fs_exists;
    fs.ExpandFilePath = fs_expand;
    fs.ReadWholeFile = fs_read;
    fs.WriteWholeFile = fs_write;
    fs.user_data = r;
    return fs;
}

/* A GLB's container, checked before tinygltf reads it: Debian's tinygltf 2.7 bounds the BIN chunk's length
   without the chunk's own 8-byte header, so a BIN chunk claiming up to 8 bytes past the end was copied from
   past the end of the file (found by fuzz_gltf: corpus/gltf/regress_glb_bin_chunk_past_end.glb).
   Returns "" when the chunks fit, else what is wrong. */
std::string glb_check(const std::vector<unsigned char> &b) {
    auto u32 = [&b](size_t o) { return (uint64_t)b[o] | (uint64_t)b[o + 1] << 8 | (uint64_t)b[o + 2] << 16 | (uint64_t)b[o + 3] << 24; };
    if (b.size() < 20) return "shorter than a GLB header and its JSON chunk header (20 bytes)";
    if (std::memcmp(b.data(), "glTF", 4)) return "not a GLB file (no 'glTF' magic)";
    if (u32(4) != 2) return "GLB version " + std::to_string(u32(4)) + " (version 2 is read)";
    uint64_t length = u32(8), end = 20 + u32(12);
    if (length > b.size()) return "the header claims " + std::to_string(length) + " bytes, the file has " + std::to_string(b.size());
    if (u32(16) != 0x4E4F534Au) return "the first chunk is not the JSON chunk";
    if (end > length) return "the JSON chunk (" + std::to_string(u32(12)) + " bytes) runs past the GLB's " + std::to_string(length) + " bytes";
    if (end + 8 <= length && end + 8 + u32((size_t)end) > length)
        return "the second chunk (" + std::to_string(u32((size_t)end)) + " bytes at byte " + std::to_string(end + 8) + ") runs past the GLB's " +
               std::to_string(length) + " bytes";
    return "";
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

void png_to_vec(void *ctx, void *data, int n);
bool write_atomic(const std::string &path, const void *data, size_t n);
bool write_png(const std::string &path, const float *data, int w, int h, int ch) {
    std::vector<unsigned char> b((size_t)w * h * ch), png;
    for (size_t i = 0; i < b.size(); i++) {
        float v = data[i];
        v = v < 0 ? 0 : v > 1 ? 1 : v;
        b[i] = (unsigned char)(v * 255.0f + 0.5f);
    }
    return stbi_write_png_to_func(png_to_vec, &png, w, h, ch, b.data(), w * ch) != 0 && write_atomic(path, png.data(), png.size());
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
    case SUPERMAT_UV_DEBUG_INPUT_COLOR: name = "input_color"; break;
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
/* n bytes to a new descriptor, fsync()ed and closed: every step checked */
bool write_fd(int fd, const void *data, size_t n) {
    const unsigned char *p = (const unsigned char *)data;
    bool ok = true;
    while (n > 0 && ok) {
        ssize_t w = ::write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        ok = w > 0;
        if (ok) { p += w; n -= (size_t)w; }
    }
    ok = fsync(fd) == 0 && ok;
    ok = close(fd) == 0 && ok;
    return ok;
}
/* a new file (O_EXCL | O_NOFOLLOW: never an existing file or a link), written in full or not at all */
bool write_file(const std::string &path, const void *data, size_t n) {
    int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0) return false;
    if (write_fd(fd, data, n)) return true;
    unlink(path.c_str());
    return false;
}

/* path written as a whole or not at all, in the folder its name says: a new temporary file beside it
   (O_EXCL | O_NOFOLLOW), fsync, renameat (which replaces a link at path, never follows it) */
bool write_atomic(const std::string &path, const void *data, size_t n) {
    size_t s = path.find_last_of('/');
    std::string dir = s == std::string::npos ? "." : s == 0 ? "/" : path.substr(0, s), name = s == std::string::npos ? path : path.substr(s + 1);
    char msg[512], tmp[256];
    int dfd = smio_dir_open(dir.c_str(), "", 0, msg, sizeof msg);
    if (dfd < 0) return false;
    int fd = smio_tmp_create(dfd, name.c_str(), tmp, sizeof tmp);
    bool ok = fd >= 0;
    if (ok) {
        ok = write_fd(fd, data, n) && renameat(dfd, tmp, dfd, name.c_str()) == 0;
        if (!ok) unlinkat(dfd, tmp, 0);
    }
    close(dfd);
    return ok;
}
void png_to_vec(void *ctx, void *data, int n) {
    std::vector<unsigned char> *v = (std::vector<unsigned char> *)ctx;
    v->insert(v->end(), (unsigned char *)data, (unsigned char *)data + n);
}


std::string base64(const unsigned char *p, size_t n) {
    static const char *t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string s;
    s.reserve((n + 2) / 3 * 4);
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)p[i] << 16 | (i + 1 < n ? (unsigned)p[i + 1] << 8 : 0) | (i + 2 < n ? p[i + 2] : 0);
        s += t[v >> 18 & 63]; s += t[v >> 12 & 63];
        s += i + 1 < n ? t[v >> 6 & 63] : '=';
        s += i + 2 < n ? t[v & 63] : '=';
    }
    return s;
}
/* %XX decoded, as tinygltf reads a URI */
std::string uri_decode(const std::string &u) {
    std::string s;
    for (size_t i = 0; i < u.size(); i++) {
        if (u[i] == '%' && i + 2 < u.size() && std::isxdigit((unsigned char)u[i + 1]) && std::isxdigit((unsigned char)u[i + 2])) {
            s += (char)std::strtol(u.substr(i + 1, 2).c_str(), nullptr, 16);
            i += 2;
        } else s += u[i];
    }
    return s;
}
/* a relative path inside the asset's folder: no scheme, not absolute, no '..' */
bool uri_inside(const std::string &decoded) {
    if (decoded.empty() || decoded[0] == '/' || decoded.find(':') != std::string::npos || decoded.find('\\') != std::string::npos) return false;
    size_t a = 0;
    for (;;) {
        size_t b = decoded.find('/', a);
        std::string part = decoded.substr(a, b == std::string::npos ? std::string::npos : b - a);
        if (part == ".." || part.empty()) return false;
        if (b == std::string::npos) return true;
        a = b + 1;
    }
}
/* a relative path as a URI: bytes outside [A-Za-z0-9-._~/] %-encoded */
std::string uri_encode(const std::string &p) {
    static const char *hex = "0123456789ABCDEF";
    std::string u;
    for (unsigned char c : p) {
        if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~' || c == '/') u += (char)c;
        else { u += '%'; u += hex[c >> 4]; u += hex[c & 15]; }
    }
    return u;
}
/* "sub/name.ext" with "-k" before its extension (k = 0: as it is) */
std::string with_suffix(const std::string &rel, int k) {
    if (k == 0) return rel;
    size_t sl = rel.find_last_of('/'), dot = rel.find_last_of('.');
    if (dot == std::string::npos || (sl != std::string::npos && dot < sl) || dot == (sl == std::string::npos ? 0 : sl + 1))
        return rel + "-" + std::to_string(k);
    return rel.substr(0, dot) + "-" + std::to_string(k) + rel.substr(dot);
}
/* is rel one of anchor's names (anchor itself or anchor-k)? */
bool in_family(const std::string &rel, const std::string &anchor) {
    if (rel == anchor) return true;
    for (int k = 1; k < 1000; k++) if (with_suffix(anchor, k) == rel) return true;
    return false;
}
/* the files (decoded relative URIs) a .gltf's JSON refers to: its buffers' and images' URIs; data URIs left
   out; empty when it does not parse */
std::vector<std::string> gltf_refs(const std::vector<unsigned char> &text) {
    std::vector<std::string> r;
    nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return r;
    for (const char *key : {"buffers", "images"}) {
        auto a = j.find(key);
        if (a == j.end() || !a->is_array()) continue;
        for (const auto &e : *a) {
            if (!e.is_object()) continue;
            auto u = e.find("uri");
            if (u == e.end() || !u->is_string()) continue;
            std::string s = u->get<std::string>();
            if (s.compare(0, 5, "data:") != 0) r.push_back(uri_decode(s));
        }
    }
    return r;
}
/* The removals a --force run over a .gltf owes once its new .gltf is in place: the older side files the
   replaced .gltf referred to that the new one does not (names of the same outputs: NAME or NAME-k). The
   list is kept in the stage (PENDING_FILE: the .gltf's name, then one file a line) until they are gone, so
   a run killed in between leaves them to the next run in that folder (finish_pending). */
const char *const PENDING_FILE = ".supermat-pending";
void remove_unreferenced(int out_fd, const std::string &out_dir, const std::string &gltf_name, const std::vector<std::string> &names) {
    std::vector<unsigned char> now = read_whole(out_dir + "/" + gltf_name, true);
    if (now.empty()) return; /* nothing proves they are unreferenced */
    std::vector<std::string> refs = gltf_refs(now);
    for (const std::string &n : names) {
        if (std::find(refs.begin(), refs.end(), n) != refs.end() || !uri_inside(n)) continue;
        size_t sl = n.find_last_of('/');
        char msg[512];
        int dfd = sl == std::string::npos ? dup(out_fd) : smio_dir_open(out_dir.c_str(), n.substr(0, sl).c_str(), 0, msg, sizeof msg);
        if (dfd < 0) continue;
        struct stat st;
        std::string leaf = sl == std::string::npos ? n : n.substr(sl + 1);
        if (fstatat(dfd, leaf.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode)) (void)unlinkat(dfd, leaf.c_str(), 0);
        close(dfd);
    }
}
/* the removals that killed runs owed in out_dir (their marked stages, processes gone); before
   smio_clean_stale removes the stages */
void finish_pending(int out_fd, const std::string &out_dir) {
    int fd = dup(out_fd);
    DIR *d = fd >= 0 ? fdopendir(fd) : nullptr;
    if (!d) { if (fd >= 0) close(fd); return; }
    while (struct dirent *e = readdir(d)) {
        int stage = 0;
        long pid = smio_leftover_pid(e->d_name, &stage);
        if (!stage || !smio_pid_gone(pid)) continue;
        std::string sd = out_dir + "/" + e->d_name;
        struct stat st;
        if (lstat(sd.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || lstat((sd + "/" SMIO_STAGE_MARKER).c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
        std::vector<unsigned char> p = read_whole(sd + "/" + PENDING_FILE, true);
        std::vector<std::string> lines;
        std::string cur;
        for (unsigned char c : p) { if (c == '\n') { lines.push_back(cur); cur.clear(); } else cur += (char)c; }
        if (lines.size() < 2 || lines[0].find('/') != std::string::npos) continue;
        remove_unreferenced(out_fd, out_dir, lines[0], std::vector<std::string>(lines.begin() + 1, lines.end()));
    }
    closedir(d);
}

std::string mime_of(const std::vector<unsigned char> &b, const std::string &given) {
    if (b.size() >= 8 && std::memcmp(b.data(), "\x89PNG", 4) == 0) return "image/png";
    if (b.size() >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return "image/jpeg";
    return given;
}
std::string ext_of_mime(const std::string &m) {
    if (m == "image/png") return "png";
    if (m == "image/jpeg") return "jpg";
    if (m == "image/webp") return "webp";
    if (m == "image/ktx2") return "ktx2";
    return "bin";
}
void mkdirs(const std::string &path) { /* every folder of path (a file's folder: up to its last '/') */
    for (size_t s = path.find('/', 1); s != std::string::npos; s = path.find('/', s + 1)) mkdir(path.substr(0, s).c_str(), 0777);
}

/* image bytes as the file holds them: tinygltf hands them to this loader, which keeps them (every image
   is written back byte for byte) and reads only the size; base colours are decoded when baked */
/* the largest base colour texture decoded (8192 x 8192): more is refused before decoding */
const int MAX_TEXTURE_PIXELS = 1 << 26;

struct Raw {
    std::vector<std::vector<unsigned char>> bytes; /* per image; empty = a file that could not be read */
    const tinygltf::Model *model = nullptr;         /* the model being loaded (its buffers come first) */
};
bool raw_image_loader(tinygltf::Image *image, const int idx, std::string *err, std::string *, int, int, const unsigned char *bytes,
                      int size, void *user) {
    Raw *r = (Raw *)user;
    if (idx < 0 || size < 0) return false;
    if (r->model && image->bufferView >= 0) { /* tinygltf hands over bufferView bytes without checking them against the buffer */
        const tinygltf::Model &m = *r->model;
        if ((size_t)image->bufferView >= m.bufferViews.size()) return false;
        const tinygltf::BufferView &bv = m.bufferViews[(size_t)image->bufferView];
        if (bv.buffer < 0 || (size_t)bv.buffer >= m.buffers.size()) return false;
        const std::vector<unsigned char> &b = m.buffers[(size_t)bv.buffer].data;
        if (bv.byteOffset > b.size() || bv.byteLength > b.size() - bv.byteOffset || (size_t)size > bv.byteLength) {
            if (err) *err += "image " + std::to_string(idx) + ": its bufferView lies outside its buffer\n";
            return false;
        }
    }
    if ((size_t)idx >= r->bytes.size()) r->bytes.resize((size_t)idx + 1);
    r->bytes[idx].assign(bytes, bytes + size);
    int w = 0, h = 0, c = 0;
    if (!supermat_cli_picture_check(bytes, (size_t)size) && stbi_info_from_memory(bytes, size, &w, &h, &c)) { image->width = w; image->height = h; image->component = c; image->bits = 8; }
    return true;
}

/* how each output image is stored */
enum Store { STORE_FILE, STORE_DATA_URI, STORE_VIEW };
struct Writer {
    std::string in_dir, out_dir, stage;
    const tinygltf::Model *model = nullptr;
    const Raw *raw = nullptr;
    std::vector<bool> write;    /* per image: its bytes go into the stage under its (decoded) URI */
    std::string failed;         /* the first file that could not be written */
};
bool image_writer(const std::string *, const std::string *, const tinygltf::Image *image, bool, std::string *out_uri, void *user) {
    Writer *w = (Writer *)user;
    *out_uri = image->uri;
    if (image->uri.compare(0, 5, "data:") == 0) return true;
    size_t i = (size_t)(image - w->model->images.data());
    if (i < w->write.size() && w->write[i]) {
        std::string rel = uri_decode(image->uri), path = w->stage + "/" + rel;
        const std::vector<unsigned char> &b = w->raw->bytes[i];
        mkdirs(path);
        /* two images may name one file: written once (the same bytes), never through anything */
        if (!write_file(path, b.data(), b.size()) && !(errno == EEXIST && read_whole(path, true) == b) && w->failed.empty())
            w->failed = w->out_dir + "/" + rel;
    }
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

/* the mesh defaults, looked for in the default model's folder (models/, or <prefix>/share/supermat) */
#define MESH_DEFAULT_MV "supermat_mv_default.safetensors"
#define MESH_DEFAULT_BC "supermat_refine_albedo_default.safetensors"
#define MESH_DEFAULT_RM "supermat_refine_rm_default.safetensors"

/* A loaded model and the read-only mapping of its file (which it borrows: small tensors, and a
   pre-packed file's panels). In a batch (supermat_cli_mesh_keep_models) the models stay loaded from one
   asset to the next, keyed by path; otherwise each run releases them. */
struct LoadedModel {
    supermat_model *m = nullptr;
    void *map = nullptr;
    size_t size = 0;
};
std::map<std::string, LoadedModel> g_models;
bool g_keep_models = false;
size_t g_max_memory = 0; /* --max-memory: 0 = no cap */

/* bytes the loaded models hold (their share of --max-memory) */
size_t models_held() {
    size_t n = 0;
    for (auto &e : g_models) {
        supermat_model_info mi;
        std::memset(&mi, 0, sizeof mi);
        supermat_model_get_info(e.second.m, &mi);
        n += mi.model_bytes;
    }
    return n;
}
/* what is left of --max-memory once the models hold theirs (1 when nothing is: refuse everything) */
size_t budget_left() {
    if (!g_max_memory) return 0;
    size_t held = models_held();
    return g_max_memory > held ? g_max_memory - held : 1;
}

/* "4G", "512M", "1.5GiB", "100000": bytes (powers of 1024); false for anything else */
bool parse_size(const std::string &s, size_t *out) {
    char *end = nullptr;
    errno = 0;
    double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || errno || !(v >= 1)) return false;
    std::string unit(end);
    for (char &ch : unit) ch = (char)std::toupper((unsigned char)ch);
    static const char *const units[] = {"", "B", "K", "KB", "KIB", "M", "MB", "MIB", "G", "GB", "GIB", "T", "TB", "TIB"};
    static const double muls[] = {1, 1, 1024.0, 1024.0, 1024.0, 1048576.0, 1048576.0, 1048576.0, 1073741824.0, 1073741824.0,
                                  1073741824.0, 1099511627776.0, 1099511627776.0, 1099511627776.0};
    for (size_t k = 0; k < sizeof units / sizeof units[0]; k++)
        if (unit == units[k]) {
            if (v * muls[k] > 1.8e19) return false;
            *out = (size_t)(v * muls[k]);
            return true;
        }
    return false;
}

void release_models() {
    for (auto &e : g_models) {
        supermat_model_destroy(e.second.m);
        if (e.second.map) munmap(e.second.map, e.second.size);
    }
    g_models.clear();
}

bool load_model(const char *path, supermat_model **m) {
    auto it = g_models.find(path);
    if (it != g_models.end()) { *m = it->second.m; return true; }
    LoadedModel lm;
    char why[256];
    int fd = smio_open_regular(path, 0, why, sizeof why); /* never blocks on a FIFO */
    struct stat st;
    if (fd < 0 || fstat(fd, &st) != 0 || st.st_size <= 0) {
        std::fprintf(stderr, "supermat mesh: cannot read %s: %s\n", path, fd < 0 ? why : "an empty file");
        if (fd >= 0) close(fd);
        return false;
    }
    lm.size = (size_t)st.st_size;
    lm.map = mmap(nullptr, lm.size, PROT_READ, MAP_PRIVATE, fd, 0);
    close(fd);
    if (lm.map == MAP_FAILED) { std::fprintf(stderr, "supermat mesh: cannot map %s: %s\n", path, std::strerror(errno)); return false; }
    supermat_model_desc md;
    std::memset(&md, 0, sizeof md);
    md.data = lm.map; md.size = lm.size;
    md.max_memory = budget_left();
    char v[16];
    if (supermat_safetensors_metadata(lm.map, lm.size, "supermat.packed.conv", v, sizeof v) == 0 && std::atoi(v) > 0 && std::atoi(v) < SUPERMAT_CONV_COUNT)
        md.conv = (supermat_conv)std::atoi(v); /* a pre-packed file runs with the options it was packed for */
    if (supermat_safetensors_metadata(lm.map, lm.size, "supermat.packed.compute", v, sizeof v) == 0 && std::atoi(v) > 0 && std::atoi(v) < SUPERMAT_COMPUTE_COUNT)
        md.compute = (supermat_compute)std::atoi(v);
    supermat_error err;
    supermat_result r = supermat_model_create(&md, &lm.m, &err);
    if (r != SUPERMAT_SUCCESS) {
        std::fprintf(stderr, "supermat mesh: %s: %s\n", path, err.message);
        munmap(lm.map, lm.size);
        return false;
    }
    *m = lm.m;
    g_models[path] = lm;
    supermat_model_info mi;
    std::memset(&mi, 0, sizeof mi);
    supermat_model_get_info(lm.m, &mi);
    std::fprintf(stderr, "supermat mesh: loaded %s (%.1f MiB held%s)\n", path, mi.model_bytes / 1048576.0, mi.prepacked ? ", pre-packed: panels used in place" : "");
    return true;
}

/* the first instance of each mesh, depth first from the roots: its world matrix. Each node is walked once:
   glTF's nodes form a forest, and a file whose nodes share children (a DAG of depth 64 has 2^64 paths) must
   not make the walk exponential (found by fuzz_gltf: corpus/gltf/regress_shared_children.gltf) */
void collect_meshes(const tinygltf::Model &m, int node, const Mat4 &parent, int depth, std::vector<int> &found,
                    std::vector<Mat4> &world, std::vector<char> &seen) {
    if (node < 0 || node >= (int)m.nodes.size() || depth > 64 || seen[node]) return;
    seen[node] = 1;
    Mat4 w = parent * node_local(m.nodes[node]);
    int me = m.nodes[node].mesh;
    if (me >= 0 && me < (int)m.meshes.size() && !found[me]) { found[me] = 1; world[me] = w; }
    for (int c : m.nodes[node].children) collect_meshes(m, c, w, depth + 1, found, world, seen);
}

/* normals: the inverse transpose of the 3x3 part (cofactor matrix, up to a positive scale); false when
   the transform mirrors */
bool normal_matrix(const Mat4 &world, double Nm[9]) {
    double A[9];
    for (int c = 0; c < 3; c++) for (int r = 0; r < 3; r++) A[r * 3 + c] = world.m[c * 4 + r];
    Nm[0] = A[4] * A[8] - A[5] * A[7]; Nm[1] = A[5] * A[6] - A[3] * A[8]; Nm[2] = A[3] * A[7] - A[4] * A[6];
    Nm[3] = A[2] * A[7] - A[1] * A[8]; Nm[4] = A[0] * A[8] - A[2] * A[6]; Nm[5] = A[1] * A[6] - A[0] * A[7];
    Nm[6] = A[1] * A[5] - A[2] * A[4]; Nm[7] = A[2] * A[3] - A[0] * A[5]; Nm[8] = A[0] * A[4] - A[1] * A[3];
    double det = A[0] * Nm[0] + A[1] * Nm[1] + A[2] * Nm[2];
    if (det < 0) for (int i = 0; i < 9; i++) Nm[i] = -Nm[i];
    return det >= 0;
}

bool is_triangles(const tinygltf::Primitive &p) { return p.mode == TINYGLTF_MODE_TRIANGLES || p.mode == -1; }

} // namespace

/* a batch keeps the models loaded from one asset to the next (keep = 1), then releases them (keep = 0) */
extern "C" void supermat_cli_mesh_keep_models(int keep) {
    g_keep_models = keep != 0;
    if (!keep) release_models();
}

/* cli/model.c: the default model's path (what `supermat image` runs without --model); 0 after a
   message when there is none */
extern "C" int supermat_cli_default_model(char *path, size_t cap, const char **from);
/* cli/model.c: a named model's file (official-mv, official-refine-albedo, official-refine-rm); 0 after a message */
extern "C" int supermat_cli_named_model(const char *name, char *path, size_t cap);

/* The options of one `supermat mesh` run, parsed and checked once: by the command itself, and by `batch mesh`
   (before any asset) for all of its assets. */
struct supermat_cli_mesh_opts {
    const char *mv_path = nullptr, *bc_path = nullptr, *rm_path = nullptr, *dbg = nullptr;
    int official = 0; /* --model official */
    int work_opt = -1; /* --work-size: -1 = each model file's own, 0 = native (the view / texture size), N */
    float detail = -1.0f; /* --detail: -1 = 1/32 with networks, off with --passthrough */
    float detail_limit = 0.0f; /* --detail-limit: 0 = supermat_uv.h's default, SUPERMAT_OFF = unbounded */
    int passthrough = 0, refine = 0, keep_observed = 0, size = 1024, views = 512, threads = 0, gutter = 0,
        edge_reject = 0, supersample = 0, policy = 0; /* policy: 0 refuse existing outputs, 1 --force, 2 --skip-existing */
    int no_refine = 0; /* --no-refine: only the option checks read it (the bake follows from the others) */
    supermat_uv_weight weight = SUPERMAT_UV_WEIGHT_AVERAGE;
    bool allow_outside = false;
    size_t max_memory = 0; /* --max-memory: 0 = no cap */
};

/* `supermat mesh`: its options (one table: the parser below and --help come from it). The ids count from
   SUPERMAT_CLI_MESH_OPT_FIRST, clear of the ids of `supermat batch`, which parses the bake options with its
   own (supermat_cli_mesh_bake_options) and hands each to supermat_cli_mesh_opt_set. */
enum {
    MESH_O_MV = 300, MESH_O_ALBEDO_REFINE, MESH_O_RM_REFINE, MESH_O_REFINE, MESH_O_NO_REFINE, MESH_O_PASSTHROUGH,
    MESH_O_KEEP_OBSERVED, MESH_O_TEXTURE_SIZE, MESH_O_VIEWS_SIZE, MESH_O_VIEW_WEIGHT, MESH_O_WORK_SIZE, MESH_O_DETAIL,
    MESH_O_THREADS, MESH_O_GUTTER, MESH_O_EDGE_REJECT, MESH_O_SUPERSAMPLE, MESH_O_MAX_MEMORY, MESH_O_DEBUG_DIR,
    MESH_O_FORCE, MESH_O_SKIP_EXISTING, MESH_O_ALLOW_OUTSIDE, MESH_O_MODEL, MESH_O_DETAIL_LIMIT
};
/* what every asset of a run shares: `supermat mesh`'s options, and those `batch mesh` passes on */
extern "C" const cli_optdef supermat_cli_mesh_bake_options[] = {
    {MESH_O_MODEL, "--model", "NAME", "official: the official SuperMatMV and both official UV-refine networks, from\n"
                                      "the model folder that `supermat download official` fills ($SUPERMAT_MODEL_DIR,\n"
                                      "else the user's data folder: `supermat info` lists them); with --no-refine the\n"
                                      "SuperMatMV alone. default: the defaults (as no model flag)", NULL, NULL},
    {MESH_O_MV, "--mv-model", "F", "a SuperMatMV model (the six views together), or a single-view model (view by\n"
                                   "view, no cross-view attention: the paper's ablation)", NULL, NULL},
    {MESH_O_REFINE, "--refine", NULL, "also the UV-refine defaults in that folder, each where present (neither:\n"
                                      "exit 1): " MESH_DEFAULT_BC " and\n"
                                      MESH_DEFAULT_RM "; with --mv-model too, that view model", NULL, NULL},
    {MESH_O_ALBEDO_REFINE, "--albedo-refine", "F", "the UV-refine networks, either or both (the same file may serve both;\n"
                                                   "with --mv-model); a map without one is the view model's", NULL, NULL},
    {MESH_O_RM_REFINE, "--rm-refine", "F", "(as --albedo-refine: the roughness / metallic one)", NULL, NULL},
    {MESH_O_PASSTHROUGH, "--passthrough", NULL, "no networks: albedo = the rendered base colour, roughness 0.5, metallic 0", NULL, NULL},
    {MESH_O_NO_REFINE, "--no-refine", NULL, "the view model alone (what no refine flag does): its back-projected maps,\n"
                                            "unseen texels filled from their neighbours (the refine networks' inputs;\n"
                                            "the paper's ablation without refinement)", NULL, NULL},
    {MESH_O_KEEP_OBSERVED, "--keep-observed", NULL, "the refined maps fill only the texels no view saw; the others keep the\n"
                                                    "back-projection (default: refined everywhere, as the official pipeline)", NULL, NULL},
    {MESH_O_TEXTURE_SIZE, "--texture-size", "N", "output texture size (default 1024)", "--size", NULL},
    {MESH_O_VIEWS_SIZE, "--views-size", "N", "rendered views (default 512)", NULL, NULL},
    {MESH_O_VIEW_WEIGHT, "--view-weight", "W", "average | cos: how the views' texels are blended (default average; cos: by\n"
                                               "the cosine of the view angle, supermat_uv.h WEIGHT)", "--weight", NULL},
    {MESH_O_WORK_SIZE, "--work-size", "N|native", "the networks' size: views (and UV maps) are resampled to N x N and the\n"
                                                  "maps back (default: the size each model file records, as `supermat image`:\n"
                                                  "128 for the multi-view default; native = the view / texture size)", NULL, NULL},
    {MESH_O_DETAIL, "--detail", "F|off", "the albedo keeps the input texture's detail: input x low-pass(albedo) /\n"
                                         "low-pass(input), lighting assumed smooth over F x the texture size\n"
                                         "(default: what the view model's file records, 1/32 for the multi-view\n"
                                         "default, none for an official file; off with --passthrough; supermat_uv.h DETAIL)", NULL, NULL},
    {MESH_O_DETAIL_LIMIT, "--detail-limit", "R|off", "the input's detail moves the albedo at most R times above or below the\n"
                                                     "input's low-pass (default 4: a shadow, highlight or reflection baked into\n"
                                                     "the input counts at most 4x); off: unbounded, as before 2026-12-08\n"
                                                     "(supermat_uv.h DETAIL)", NULL, NULL},
    {MESH_O_THREADS, "--threads", "N", "threads (default 0 = all cores)", NULL, NULL},
    {MESH_O_GUTTER, "--gutter", "N", "texels filled around the baked ones (default 0 = 16; < 0 the whole texture)", NULL, NULL},
    {MESH_O_EDGE_REJECT, "--edge-reject", "N", "view pixels closer than N to a silhouette or depth edge left out (default 0)", NULL, NULL},
    {MESH_O_SUPERSAMPLE, "--supersample", "N", "samples per view pixel per axis, 1 to 8 (default 0 = 4)", NULL, NULL},
    {MESH_O_MAX_MEMORY, "--max-memory", "SIZE", "refuse models + bake needing more than SIZE (512M, 4G), before allocating", NULL, NULL},
    CLI_END};
/* the output files' options: in the `supermat` CLI these are its global options (main() takes them from
   anywhere on the command line and passes them in: supermat_cli_mesh_global); the standalone supermat_mesh
   and supermat_cli_mesh() callers parse them here */
static const cli_optdef mesh_opts_files[] = {
    {MESH_O_FORCE, "--force", NULL, "replace existing output files (default: refuse them)", NULL, NULL},
    {MESH_O_SKIP_EXISTING, "--skip-existing", NULL, "keep an existing OUT and exit 0", NULL, NULL},
    {MESH_O_ALLOW_OUTSIDE, "--allow-outside-refs", NULL, "trusted assets only: read referenced files outside IN's folder (by '..' or\n"
                                                         "a symbolic link); absolute paths, schemes and non-regular files stay\n"
                                                         "refused", NULL, NULL},
    CLI_END};
static const cli_optdef mesh_opts[] = {
    CLI_TEXT("usage: supermat mesh [--model official | --mv-model F] [--refine | --albedo-refine F | --rm-refine F | --no-refine]\n"
             "       IN.gltf OUT.gltf\n"
             "       [--passthrough] [--keep-observed] [--debug-dir DIR] [--texture-size N] [--views-size N] [--threads N]\n"
             "       [--gutter N] [--edge-reject N] [--view-weight average|cos] [--supersample N] [--detail F|off]\n"
             "       [--detail-limit R|off]\n"
             "\n"
             "Bakes albedo and metallicRoughness UV textures for the glTF asset IN (.gltf or .glb) into OUT.\n"
             "No model flags: the view model in the default model's folder (as `supermat image` finds it):\n"
             MESH_DEFAULT_MV " (else the default model, view by view), without refinement\n"
             "(measured better than with the refine networks trained here: docs/mesh.md).\n"
             "\n"
             "options:\n"),
    CLI_OPTS(supermat_cli_mesh_bake_options),
    {MESH_O_DEBUG_DIR, "--debug-dir", "DIR", "write view_K.png, pred_albedo_K.png, pred_rm_K.png, partial_albedo.png,\n"
                                             "partial_rm.png, mask.png, position.png there (suffix _M for the M-th\n"
                                             "material after the first)", NULL, NULL},
    CLI_OPTS(mesh_opts_files),
    CLI_END};

/* one option (id, v) of mesh_opts into o: 1, or -1 after a usage message */
static int mesh_opt_value(supermat_cli_mesh_opts &o, int id, const char *v) {
    std::string w = v ? v : "";
    char *end = nullptr;
    switch (id) {
    case MESH_O_MODEL:
        if (w == "official") o.official = 1;
        else if (w == "default") o.official = 0;
        else return cli_usage_error("mesh", "--model: official or default, not '%s' (model files: --mv-model, --albedo-refine, --rm-refine)", v), -1;
        break;
    case MESH_O_MV: o.mv_path = v; break;
    case MESH_O_ALBEDO_REFINE: o.bc_path = v; break;
    case MESH_O_RM_REFINE: o.rm_path = v; break;
    case MESH_O_DEBUG_DIR: o.dbg = v; break;
    case MESH_O_TEXTURE_SIZE: o.size = std::atoi(v); break;
    case MESH_O_VIEWS_SIZE: o.views = std::atoi(v); break;
    case MESH_O_THREADS: o.threads = std::atoi(v); break;
    case MESH_O_GUTTER: o.gutter = std::atoi(v); break;
    case MESH_O_EDGE_REJECT: o.edge_reject = std::atoi(v); break;
    case MESH_O_SUPERSAMPLE: o.supersample = std::atoi(v); break;
    case MESH_O_WORK_SIZE:
        o.work_opt = w == "native" ? 0 : std::atoi(v);
        if (w != "native" && (o.work_opt < 8 || o.work_opt % 8 || o.work_opt > 16384)) {
            std::fprintf(stderr, "supermat mesh: --work-size: 'native' or a multiple of 8 from 8 to 16384, not '%s'\n", v);
            return -1;
        }
        break;
    case MESH_O_DETAIL:
        o.detail = w == "off" ? 0.0f : std::strtof(v, &end);
        if (w != "off" && (!end || *end || !(o.detail >= 0.0f && o.detail <= 1.0f))) {
            std::fprintf(stderr, "supermat mesh: --detail: 'off' or a fraction of the texture size from 0 to 1, not '%s'\n", v);
            return -1;
        }
        break;
    case MESH_O_DETAIL_LIMIT:
        o.detail_limit = w == "off" ? SUPERMAT_OFF : std::strtof(v, &end);
        if (w != "off" && (!end || *end || !(o.detail_limit > 1.0f && o.detail_limit <= 1e6f))) {
            std::fprintf(stderr, "supermat mesh: --detail-limit: 'off' or a ratio above 1 (at most 1e6), not '%s'\n", v);
            return -1;
        }
        break;
    case MESH_O_MAX_MEMORY:
        if (!parse_size(w, &o.max_memory)) {
            std::fprintf(stderr, "supermat mesh: --max-memory: '%s' is not a size (bytes, or a number with K, M, G or T: 512M, 2.5G)\n", v);
            return -1;
        }
        break;
    case MESH_O_VIEW_WEIGHT:
        if (w == "cos") o.weight = SUPERMAT_UV_WEIGHT_COS_POWER;
        else if (w == "average") o.weight = SUPERMAT_UV_WEIGHT_AVERAGE;
        else return cli_usage_error("mesh", "--view-weight: average or cos, not '%s'", v), -1;
        break;
    case MESH_O_PASSTHROUGH: o.passthrough = 1; break;
    case MESH_O_NO_REFINE: o.no_refine = 1; break;
    case MESH_O_REFINE: o.refine = 1; break;
    case MESH_O_KEEP_OBSERVED: o.keep_observed = 1; break;
    case MESH_O_ALLOW_OUTSIDE: o.allow_outside = true; break;
    case MESH_O_FORCE:
    case MESH_O_SKIP_EXISTING: {
        int want = id == MESH_O_FORCE ? 1 : 2;
        if (o.policy && o.policy != want) return cli_usage_error("mesh", "--force and --skip-existing exclude each other"), -1;
        o.policy = want;
        break;
    }
    default: return cli_usage_error("mesh", "option %d is not one of mesh's", id), -1;
    }
    return 1;
}

/* the checks across options, once all are in: 0, or 2 after a usage message */
static int mesh_opts_check(const supermat_cli_mesh_opts &o) {
    int no_refine = o.no_refine;
    if (o.official && (o.passthrough || o.mv_path || o.bc_path || o.rm_path || o.refine)) {
        std::fprintf(stderr, "supermat mesh: --model official names all three networks: not with %s\n",
                     o.passthrough ? "--passthrough" : o.refine ? "--refine" : "--mv-model, --albedo-refine or --rm-refine");
        return 2;
    }
    if (no_refine && (o.passthrough || o.bc_path || o.rm_path || o.refine)) {
        std::fprintf(stderr, "supermat mesh: --no-refine takes --mv-model alone (no --refine, --albedo-refine, --rm-refine or --passthrough)\n");
        return 2;
    }
    if (o.refine && (o.passthrough || o.bc_path || o.rm_path)) {
        std::fprintf(stderr, "supermat mesh: --refine takes the default refine networks: not with %s\n",
                     o.passthrough ? "--passthrough" : "--albedo-refine or --rm-refine (name both files instead)");
        return 2;
    }
    if (!o.passthrough && !o.refine && !o.bc_path && !o.rm_path && !o.official) no_refine = 1; /* no refine flag: the view model alone */
    if (o.keep_observed && (o.passthrough || no_refine)) {
        std::fprintf(stderr, "supermat mesh: --keep-observed keeps the seen texels out of the refinement: not with %s\n",
                     o.passthrough ? "--passthrough" : "no refine network (--refine, --albedo-refine or --rm-refine)");
        return 2;
    }
    if (!o.passthrough && !o.mv_path && (o.bc_path || o.rm_path)) {
        std::fprintf(stderr, "supermat mesh: --albedo-refine and --rm-refine need --mv-model\n");
        return 2;
    }
    return 0;
}

/* argv[1..] against mesh_opts: the options, then IN and OUT where in_p is not NULL (none where it is); -1
   when they are valid (o filled), else the exit status (0 after --help, 2 after a usage message) */
static int parse_mesh_opts(int argc, char **argv, supermat_cli_mesh_opts &o, const char **in_p, const char **out_p) {
    const char *in = nullptr, *out = nullptr, *v;
    cli_argp P;
    int m;
    cli_argp_init(&P, "mesh", mesh_opts, argc, argv, 1);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, mesh_opts); return 0; }
        if (m == CLI_ARG_ERROR) return 2;
        if (m == CLI_ARG_OPERAND) {
            if (!in) in = v;
            else if (!out) out = v;
            else return cli_usage_error("mesh", "one IN and one OUT: '%s' is a third", v);
        } else if (mesh_opt_value(o, m, v) < 0)
            return 2;
    }
    if (in_p && (!in || !out)) return cli_usage_error("mesh", "give IN.gltf and OUT.gltf");
    if (!in_p && in) { std::fprintf(stderr, "supermat batch mesh: unexpected argument '%s' (the assets are the batch's inputs)\n", in); return 2; }
    if (mesh_opts_check(o)) return 2;
    if (in_p) { *in_p = in; *out_p = out; }
    return -1;
}

/* one asset, IN to OUT, with options parse_mesh_opts checked */
static int run_mesh(const supermat_cli_mesh_opts &opt, const char *in, const char *out) {
    const char *mv_path = opt.mv_path, *bc_path = opt.bc_path, *rm_path = opt.rm_path, *dbg = opt.dbg;
    int work_opt = opt.work_opt;
    float detail = opt.detail;
    int passthrough = opt.passthrough, refine = opt.refine, keep_observed = opt.keep_observed, size = opt.size,
        views = opt.views, threads = opt.threads, gutter = opt.gutter, edge_reject = opt.edge_reject, supersample = opt.supersample,
        policy = opt.policy;
    supermat_uv_weight weight = opt.weight;
    bool allow_outside = opt.allow_outside;
    g_max_memory = opt.max_memory;
    { /* OUT's folder, before any work: it must exist (and be a folder) */
        std::string od = dir_of(out);
        char msg[1024];
        int fd = smio_dir_open(od.c_str(), "", 0, msg, sizeof msg);
        if (fd < 0) { std::fprintf(stderr, "supermat mesh: cannot write %s: %s\n", out, msg); return 1; }
        close(fd);
    }
    if (exists_l(out) && policy != 1) { /* before any work */
        if (policy == 2) { std::fprintf(stderr, "kept '%s' (it exists; --skip-existing)\n", out); return 0; }
        std::fprintf(stderr, "supermat mesh: '%s' exists and was not written by this run: --force replaces it, --skip-existing keeps it\n", out);
        return 1;
    }
    static char default_path[4096], official_path[3][4096];
    static std::string default_mv, default_bc, default_rm;
    if (opt.official) { /* the official networks from the model folder (cli/model.c says where and why not) */
        static const char *const names[3] = {"official-mv", "official-refine-albedo", "official-refine-rm"};
        for (int k = 0; k < (opt.no_refine ? 1 : 3); k++)
            if (!supermat_cli_named_model(names[k], official_path[k], sizeof official_path[k])) return 1;
        mv_path = official_path[0];
        if (!opt.no_refine) { bc_path = official_path[1]; rm_path = official_path[2]; }
        if (isatty(STDERR_FILENO))
            std::fprintf(stderr, "models (--model official): %s%s%s%s%s\n", mv_path, opt.no_refine ? ", no refinement" : ", refined by ",
                         opt.no_refine ? "" : bc_path, opt.no_refine ? "" : " and ", opt.no_refine ? "" : rm_path);
    } else if (!passthrough && (!mv_path || refine)) {
        /* the mesh defaults beside the default model: with no --mv-model its SuperMatMV where it is (else the
           default single-view model, view by view); with --refine the two UV-refine networks where they are */
        const char *from = nullptr;
        if (!supermat_cli_default_model(default_path, sizeof default_path, &from)) return 1; /* it said why */
        std::string dir = dir_of(default_path);
        default_mv = dir + "/" MESH_DEFAULT_MV;
        default_bc = dir + "/" MESH_DEFAULT_BC;
        default_rm = dir + "/" MESH_DEFAULT_RM;
        bool have_mv = !mv_path && access(default_mv.c_str(), R_OK) == 0;
        bool have_bc = refine && access(default_bc.c_str(), R_OK) == 0;
        bool have_rm = refine && access(default_rm.c_str(), R_OK) == 0;
        if (refine && !have_bc && !have_rm) {
            std::fprintf(stderr, "supermat mesh: --refine: no UV-refine default in %s (%s, %s)\n", dir.c_str(), MESH_DEFAULT_BC, MESH_DEFAULT_RM);
            return 1;
        }
        bool defaulted_mv = !mv_path;
        if (!mv_path) mv_path = have_mv ? default_mv.c_str() : default_path;
        if (have_bc) bc_path = default_bc.c_str();
        if (have_rm) rm_path = default_rm.c_str();
        if (isatty(STDERR_FILENO)) {
            std::string by = have_bc && have_rm ? default_bc + " and " + default_rm : have_bc ? default_bc : have_rm ? default_rm : "";
            std::fprintf(stderr, "models (%s): %s%s%s%s\n", from, mv_path,
                         !defaulted_mv ? "" : have_mv ? " (multi-view)" : " (single view, view by view)",
                         by.empty() ? ", no refinement" : ", refined by ", by.c_str());
        }
    }
    auto t0 = std::chrono::steady_clock::now();

    /* ---- read the glTF ---- */
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    Raw raw;
    raw.model = &model;
    loader.SetImageLoader(raw_image_loader, &raw);
    std::string err, warn, inpath = in, outpath = out;
    RefFs refs;
    refs.base = dir_of(inpath);
    refs.allow_outside = allow_outside;
    {
        char *r = realpath(refs.base.c_str(), nullptr);
        if (!r) { std::fprintf(stderr, "supermat mesh: cannot read %s: its folder: %s\n", in, std::strerror(errno)); return 1; }
        refs.real_dir = r;
        std::free(r);
    }
    loader.SetFsCallbacks(ref_fs(&refs));
    bool glb_in = inpath.size() > 4 && inpath.compare(inpath.size() - 4, 4, ".glb") == 0;
    std::vector<unsigned char> glb; /* IN is read here (a regular file), checked, then parsed from memory (kept until the end) */
    {
        struct stat st;
        if (::stat(in, &st) == 0 && (uint64_t)st.st_size > 0xFFFFFFFFu) {
            std::fprintf(stderr, "supermat mesh: cannot read %s: %llu bytes (a glTF or GLB holds at most 4 GiB)\n", in, (unsigned long long)st.st_size);
            return 1;
        }
        std::string why;
        glb = read_whole(inpath, false, &why);
        if (glb.empty()) { std::fprintf(stderr, "supermat mesh: cannot read %s: it %s\n", in, why.c_str()); return 1; }
        why = glb_in ? glb_check(glb) : "";
        if (!why.empty()) { std::fprintf(stderr, "supermat mesh: cannot read %s: %s\n", in, why.c_str()); return 1; }
    }
    bool ok = glb_in ? loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), (unsigned int)glb.size(), refs.base)
                     : loader.LoadASCIIFromString(&model, &err, &warn, (const char *)glb.data(), (unsigned int)glb.size(), refs.base);
    if (!refs.refused.empty()) { /* a hostile or broken reference: nothing is read through it, and the run fails */
        for (const std::string &r : refs.refused) std::fprintf(stderr, "supermat mesh: %s: the reference %s\n", in, r.c_str());
        return 1;
    }
    if (!warn.empty()) std::fprintf(stderr, "supermat mesh: %s\n", warn.c_str());
    if (!ok) { std::fprintf(stderr, "supermat mesh: cannot read %s: %s\n", in, err.c_str()); return 1; }
    raw.bytes.resize(model.images.size());
    if (model.meshes.empty()) { std::fprintf(stderr, "supermat mesh: %s has no mesh\n", in); return 1; }

    /* ---- the meshes the scene shows (its default scene; without scenes, every root node) ---- */
    std::vector<int> found(model.meshes.size(), 0);
    std::vector<Mat4> world(model.meshes.size());
    {
        std::vector<int> roots;
        int scene = model.defaultScene >= 0 && model.defaultScene < (int)model.scenes.size() ? model.defaultScene : 0;
        if (scene < (int)model.scenes.size()) roots = model.scenes[scene].nodes;
        else {
            std::vector<int> child(model.nodes.size(), 0);
            for (const tinygltf::Node &n : model.nodes)
                for (int c : n.children) if (c >= 0 && c < (int)child.size()) child[c] = 1;
            for (size_t n = 0; n < child.size(); n++) if (!child[n]) roots.push_back((int)n);
        }
        std::vector<char> seen(model.nodes.size(), 0);
        for (int r : roots) collect_meshes(model, r, Mat4(), 0, found, world, seen);
    }
    /* a primitive is baked when its mesh is in the scene and it is a triangle list; a material that is
       also used by a primitive that is not baked gets a copy, so that those keep the original */
    std::map<int, int> baked_users, other_users; /* material -> count */
    int meshes_baked = 0;
    for (size_t mi = 0; mi < model.meshes.size(); mi++) {
        meshes_baked += found[mi];
        for (size_t pi = 0; pi < model.meshes[mi].primitives.size(); pi++) {
            const tinygltf::Primitive &p = model.meshes[mi].primitives[pi];
            if (found[mi] && is_triangles(p)) baked_users[p.material]++;
            else {
                other_users[p.material]++;
                if (found[mi]) std::fprintf(stderr, "supermat mesh: mesh %zu primitive %zu is not a triangle list (mode %d): left as it is\n", mi, pi, p.mode);
            }
        }
    }
    if (baked_users.empty()) { std::fprintf(stderr, "supermat mesh: %s: no triangle primitive in the scene's meshes\n", in); return 1; }
    std::map<int, int> effective; /* original material -> the material the baked primitives use */
    std::vector<MatIn> mats;
    std::map<int, int> output_of; /* original material -> output */
    for (const auto &bu : baked_users) {
        int orig = bu.first;
        MatIn m;
        if (orig >= (int)model.materials.size()) { std::fprintf(stderr, "supermat mesh: material %d does not exist\n", orig); return 1; }
        if (orig >= 0) {
            const tinygltf::Material &mat = model.materials[orig];
            const tinygltf::PbrMetallicRoughness &pbr = mat.pbrMetallicRoughness;
            for (int k = 0; k < 4 && k < (int)pbr.baseColorFactor.size(); k++) m.factor[k] = (float)pbr.baseColorFactor[k];
            int ti = pbr.baseColorTexture.index;
            m.texcoord = pbr.baseColorTexture.texCoord;
            if (ti >= 0 && ti < (int)model.textures.size()) {
                std::string xe;
                m.has_xf = texture_transform(pbr.baseColorTexture.extensions, &m, &xe);
                if (!xe.empty()) { std::fprintf(stderr, "supermat mesh: material %d: %s\n", orig, xe.c_str()); return 1; }
                const tinygltf::Texture &t = model.textures[ti];
                m.sampler = t.sampler;
                if (t.sampler >= 0 && t.sampler < (int)model.samplers.size()) {
                    m.wu = wrap_of(model.samplers[t.sampler].wrapS);
                    m.wv = wrap_of(model.samplers[t.sampler].wrapT);
                }
                int w = 0, h = 0, c = 0;
                unsigned char *px = nullptr;
                if (t.source >= 0 && t.source < (int)model.images.size() && !raw.bytes[t.source].empty() && raw.bytes[t.source].size() < (1u << 31)) {
                    const std::vector<unsigned char> &rb = raw.bytes[t.source];
                    /* its bytes checked first (picture_check.h), then the header: a few bytes may claim a huge
                       picture (a decompression bomb) */
                    const char *why = supermat_cli_picture_check(rb.data(), rb.size());
                    if (why)
                        std::fprintf(stderr, "supermat mesh: the base colour image of material %d %s\n", orig, why);
                    else if (stbi_info_from_memory(rb.data(), (int)rb.size(), &w, &h, &c) && (double)w * h > MAX_TEXTURE_PIXELS)
                        std::fprintf(stderr, "supermat mesh: the base colour image of material %d is %dx%d, more than %d pixels\n", orig, w, h, MAX_TEXTURE_PIXELS);
                    else if (g_max_memory && (double)w * h * 4.0 * 2.0 > (double)g_max_memory) /* decoded, and its copy */
                        std::fprintf(stderr, "supermat mesh: the base colour image of material %d (%dx%d) needs %.1f MiB decoded, more than --max-memory\n",
                                     orig, w, h, (double)w * h * 8.0 / 1048576.0);
                    else
                        px = stbi_load_from_memory(rb.data(), (int)rb.size(), &w, &h, &c, 0);
                }
                if (px) {
                    m.tw = w; m.th = h; m.tch = c;
                    m.tex.assign(px, px + (size_t)w * h * c);
                    stbi_image_free(px);
                    m.alpha = (c == 2 || c == 4) && mat.alphaMode != "OPAQUE";
                } else
                    std::fprintf(stderr, "supermat mesh: the base colour image of material %d could not be read: using its factor\n", orig);
            }
            if (other_users.count(orig)) { /* shared with primitives that are not baked: bake into a copy */
                tinygltf::Material copy = mat;
                copy.name = (mat.name.empty() ? "material " + std::to_string(orig) : mat.name) + " (supermat)";
                model.materials.push_back(copy);
                m.material = (int)model.materials.size() - 1;
            } else
                m.material = orig;
        } else { /* primitives without material: give them one */
            tinygltf::Material nm;
            nm.name = "supermat";
            model.materials.push_back(nm);
            m.material = (int)model.materials.size() - 1;
        }
        effective[orig] = m.material;
        output_of[orig] = (int)mats.size();
        mats.push_back(std::move(m));
    }

    /* ---- the baked primitives, in the world frame (glTF Y up -> Z up: (x, y, z) -> (x, -z, y)) ---- */
    std::vector<Prim> prims;
    for (size_t mi = 0; mi < model.meshes.size(); mi++) {
        if (!found[mi]) continue;
        double Nm[9];
        bool keep_winding = normal_matrix(world[mi], Nm);
        const Mat4 &W = world[mi];
        for (size_t pi = 0; pi < model.meshes[mi].primitives.size(); pi++) {
            tinygltf::Primitive &p = model.meshes[mi].primitives[pi];
            if (!is_triangles(p)) continue;
            Prim q;
            q.output = output_of[p.material];
            const MatIn &m = mats[q.output];
            q.material = m.material;
            std::string attr = "TEXCOORD_" + std::to_string(m.texcoord);
            auto pa = p.attributes.find("POSITION"), ta = p.attributes.find(attr), na = p.attributes.find("NORMAL");
            if (pa == p.attributes.end()) { std::fprintf(stderr, "supermat mesh: mesh %zu primitive %zu has no POSITION\n", mi, pi); return 1; }
            if (ta == p.attributes.end()) {
                std::fprintf(stderr, "supermat mesh: mesh %zu primitive %zu has no %s: the mesh needs UVs (unwrap it first)\n", mi, pi, attr.c_str());
                return 1;
            }
            AccessorReader P, T, N;
            if (!P.init(model, pa->second, &err, "POSITION") || !T.init(model, ta->second, &err, attr.c_str()) ||
                (na != p.attributes.end() && !N.init(model, na->second, &err, "NORMAL"))) {
                std::fprintf(stderr, "supermat mesh: mesh %zu primitive %zu: %s\n", mi, pi, err.c_str());
                return 1;
            }
            if (P.comps != 3 || T.comps != 2 || T.count != P.count || (N.base && (N.comps != 3 || N.count != P.count))) {
                std::fprintf(stderr, "supermat mesh: mesh %zu primitive %zu: attribute shapes do not match\n", mi, pi);
                return 1;
            }
            for (size_t v = 0; v < P.count; v++) {
                double x = P.get(v, 0), y = P.get(v, 1), z = P.get(v, 2), w[3];
                for (int r = 0; r < 3; r++) w[r] = W.m[r] * x + W.m[4 + r] * y + W.m[8 + r] * z + W.m[12 + r];
                q.pos.push_back((float)w[0]); q.pos.push_back((float)-w[2]); q.pos.push_back((float)w[1]);
                double u = T.get(v, 0), t = T.get(v, 1);
                if (m.has_xf) { /* bake in the transformed space; the new textures carry the same transform */
                    double u2 = m.xf[0] * u + m.xf[1] * t + m.xf[2], t2 = m.xf[3] * u + m.xf[4] * t + m.xf[5];
                    u = u2; t = t2;
                }
                q.uv.push_back((float)u); q.uv.push_back((float)t);
                if (N.base) {
                    double a = N.get(v, 0), b = N.get(v, 1), c = N.get(v, 2), n[3];
                    for (int r = 0; r < 3; r++) n[r] = Nm[r * 3] * a + Nm[r * 3 + 1] * b + Nm[r * 3 + 2] * c;
                    q.nrm.push_back((float)n[0]); q.nrm.push_back((float)-n[2]); q.nrm.push_back((float)n[1]);
                }
            }
            if (p.indices >= 0) {
                AccessorReader I;
                if (!I.init(model, p.indices, &err, "indices") || I.comps != 1 ||
                    (I.type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && I.type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT && I.type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)) {
                    std::fprintf(stderr, "supermat mesh: mesh %zu primitive %zu: %s\n", mi, pi, err.empty() ? "indices are not unsigned integer scalars" : err.c_str());
                    return 1;
                }
                for (size_t k = 0; k < I.count; k++) q.idx.push_back((uint32_t)I.get(k, 0));
            } else
                for (size_t k = 0; k < P.count; k++) q.idx.push_back((uint32_t)k);
            if (!keep_winding) /* a mirroring transform: keep the winding consistent with the normals */
                for (size_t k = 0; k + 2 < q.idx.size(); k += 3) std::swap(q.idx[k + 1], q.idx[k + 2]);
            p.material = m.material; /* the copy, or the new material of primitives without one */
            prims.push_back(std::move(q));
        }
    }

    /* ---- models ---- */
    supermat_model *mv = nullptr, *bc = nullptr, *rm = nullptr;
    if (!passthrough) {
        /* either refine network may be absent (that map stays the view model's); one file given for both loads once */
        if (!load_model(mv_path, &mv) || (bc_path && !load_model(bc_path, &bc)) || (rm_path && !load_model(rm_path, &rm))) {
            if (!g_keep_models) release_models();
            return 1;
        }
    }

    /* ---- bake ---- */
    std::vector<supermat_uv_part> parts(prims.size());
    for (size_t i = 0; i < prims.size(); i++) {
        Prim &q = prims[i];
        MatIn &m = mats[q.output];
        supermat_uv_part &p = parts[i];
        std::memset(&p, 0, sizeof p);
        p.positions = q.pos.data(); p.uvs = q.uv.data(); p.normals = q.nrm.empty() ? nullptr : q.nrm.data();
        p.vertex_count = (uint32_t)(q.pos.size() / 3);
        p.indices = q.idx.data(); p.index_count = (uint32_t)q.idx.size();
        if (!m.tex.empty()) {
            p.base_color.pixels = m.tex.data(); p.base_color.width = m.tw; p.base_color.height = m.th; p.base_color.channels = m.tch;
        }
        p.base_color_factor = m.factor;
        p.wrap_u = m.wu; p.wrap_v = m.wv;
        p.output = q.output;
    }
    int nout = (int)mats.size();
    std::vector<std::vector<unsigned char>> albedo(nout), mr(nout);
    std::vector<supermat_uv_output> outs(nout);
    for (int o = 0; o < nout; o++) {
        int bch = mats[o].alpha ? 4 : 3;
        albedo[o].resize((size_t)size * size * bch);
        mr[o].resize((size_t)size * size * 3);
        std::memset(&outs[o], 0, sizeof outs[o]);
        outs[o].base_color.pixels = albedo[o].data(); outs[o].base_color.channels = bch;
        outs[o].metallic_roughness.pixels = mr[o].data(); outs[o].metallic_roughness.channels = 3;
    }
    supermat_uv_bake_desc bd;
    std::memset(&bd, 0, sizeof bd);
    bd.parts = parts.data(); bd.part_count = (int)parts.size(); bd.output_count = nout;
    bd.texture_width = bd.texture_height = size;
    bd.view_size = views;
    /* only what the command line says: the rest (the networks' work sizes, the detail step) is what the model
       files record, applied by supermat_uv.h as for any caller */
    bd.view_work_size = bd.refine_work_size = work_opt < 0 ? 0 : work_opt == 0 ? SUPERMAT_WORK_NATIVE : work_opt;
    bd.supersample = supersample;
    bd.detail_sigma = detail < 0.0f ? 0.0f : detail == 0.0f ? SUPERMAT_OFF : detail;
    bd.detail_limit = opt.detail_limit;
    bd.passthrough = passthrough;
    bd.mv_model = mv; bd.albedo_refine_model = bc; bd.rm_refine_model = rm;
    bd.weight = weight;
    bd.gutter = gutter;
    bd.keep_observed = keep_observed;
    bd.edge_reject = edge_reject;
    bd.threads = threads;
    bd.max_memory = budget_left();
    int last = -5;
    if (isatty(2)) { bd.progress = progress_cb; bd.progress_user = &last; }
    Debug dd;
    if (dbg) {
        if (mkdir(dbg, 0777) != 0 && errno != EEXIST) { std::fprintf(stderr, "supermat mesh: cannot create %s: %s\n", dbg, std::strerror(errno)); return 1; }
        dd.dir = dbg;
        bd.debug = debug_cb; bd.debug_user = &dd;
    }
    supermat_uv_stats st;
    supermat_error serr;
    supermat_result r = supermat_uv_bake(&bd, outs.data(), &st, &serr);
    if (bd.progress) std::fprintf(stderr, "\r%-40s\r", "");
    if (!g_keep_models) release_models();
    if (r != SUPERMAT_SUCCESS) {
        std::fprintf(stderr, "supermat mesh: %s (%s)\n", serr.message, supermat_result_string(r));
        if (g_max_memory && r == SUPERMAT_ERROR_OUT_OF_MEMORY)
            std::fprintf(stderr, "  (--max-memory %.1f MiB: the models hold %.1f MiB, which leaves the bake the rest)\n",
                         g_max_memory / 1048576.0, (g_max_memory - bd.max_memory) / 1048576.0);
        return 1;
    }
    if (dd.failed) std::fprintf(stderr, "supermat mesh: could not write every debug image to %s\n", dbg);
    /* alpha (MASK / BLEND): the base colour texture's own alpha at each texel, in the same UV space */
    for (int o = 0; o < nout; o++) {
        const MatIn &m = mats[o];
        if (!m.alpha) continue;
        for (int y = 0; y < size; y++)
            for (int x = 0; x < size; x++) {
                float a = sample_channel(m, (x + 0.5) / size * m.tw, (y + 0.5) / size * m.th, m.tch - 1);
                albedo[o][((size_t)y * size + x) * 4 + 3] = (unsigned char)(a * 255.0f + 0.5f);
            }
    }

    /* ---- OUT: the new images in the texture slots they replace (a slot that only this material
       uses is reused, so that a re-run on its own output does not pile up images) ---- */
    bool glb_out = outpath.size() > 4 && outpath.compare(outpath.size() - 4, 4, ".glb") == 0;
    std::string stem = stem_of(outpath);
    bool self_contained = !glb_in; /* a .gltf without any file it refers to stays one */
    for (const tinygltf::Buffer &b : model.buffers) if (b.uri.compare(0, 5, "data:") != 0) self_contained = false;
    for (size_t i = 0; i < model.images.size(); i++)
        if (!model.images[i].uri.empty() || (model.images[i].bufferView < 0 && raw.bytes[i].empty())) self_contained = false;
    std::vector<int> texref(model.textures.size(), 0), imgref(model.images.size(), 0);
    for (const tinygltf::Material &mat : model.materials)
        for (int t : material_textures(mat)) if (t >= 0 && t < (int)texref.size()) texref[t]++;
    for (const tinygltf::Texture &t : model.textures)
        for (int s : texture_images(t)) if (s >= 0 && s < (int)imgref.size()) imgref[s]++;
    std::vector<bool> ours(model.images.size(), false);
    for (int o = 0; o < nout; o++) {
        const MatIn &m = mats[o];
        tinygltf::Material &mat = model.materials[m.material];
        tinygltf::PbrMetallicRoughness &pbr = mat.pbrMetallicRoughness;
        int base_texcoord = pbr.baseColorTexture.index >= 0 ? pbr.baseColorTexture.texCoord : 0;
        for (int k = 0; k < 2; k++) {
            tinygltf::TextureInfo &ti = k ? pbr.metallicRoughnessTexture : pbr.baseColorTexture;
            int t = ti.index, im = -1;
            /* (textures and images added for earlier outputs are past texref / imgref: never reused) */
            if (t >= 0 && t < (int)texref.size() && texref[t] == 1 && model.textures[t].extensions.empty()) {
                int s = model.textures[t].source;
                if (s >= 0 && s < (int)imgref.size() && imgref[s] == 1 && !ours[s]) im = s;
            }
            if (im < 0) { /* a new image and texture */
                model.images.push_back(tinygltf::Image());
                raw.bytes.emplace_back();
                ours.push_back(false);
                im = (int)model.images.size() - 1;
                model.textures.push_back(tinygltf::Texture());
                t = (int)model.textures.size() - 1;
                model.textures[t].source = im;
            }
            model.textures[t].sampler = m.sampler;
            ours[im] = true;
            tinygltf::Image &img = model.images[im];
            std::string keep_name = img.name;
            img = tinygltf::Image();
            img.name = keep_name;
            img.mimeType = "image/png";
            int ch = k ? 3 : (m.alpha ? 4 : 3);
            img.width = size; img.height = size; img.component = ch; img.bits = 8;
            std::vector<unsigned char> png;
            const std::vector<unsigned char> &px = k ? mr[o] : albedo[o];
            if (!stbi_write_png_to_func(png_to_vec, &png, size, size, ch, px.data(), size * ch)) {
                std::fprintf(stderr, "supermat mesh: cannot encode a PNG\n");
                return 1;
            }
            raw.bytes[im].swap(png);
            img.uri = stem + (k ? "_metallicRoughness" : "_baseColor") + (nout > 1 ? "_" + std::to_string(o) : std::string()) + ".png";
            ti = tinygltf::TextureInfo();
            ti.index = t;
            ti.texCoord = base_texcoord;
            if (m.has_xf) ti.extensions["KHR_texture_transform"] = m.xf_ext;
        }
        double alpha = pbr.baseColorFactor.size() == 4 ? pbr.baseColorFactor[3] : 1.0;
        pbr.baseColorFactor = {1.0, 1.0, 1.0, alpha}; /* the colour factor is baked into the texture */
        pbr.metallicFactor = 1.0; pbr.roughnessFactor = 1.0;
    }
    /* our names must not take an original image's name */
    {
        std::map<std::string, int> taken;
        for (size_t i = 0; i < model.images.size(); i++)
            if (!ours[i] && !model.images[i].uri.empty()) taken[uri_decode(model.images[i].uri)] = 1;
        for (size_t i = 0; i < model.images.size(); i++) {
            if (!ours[i]) continue;
            std::string u = model.images[i].uri, s = u.substr(0, u.size() - 4);
            for (int n = 2; taken.count(u); n++) u = s + "_" + std::to_string(n) + ".png";
            model.images[i].uri = u;
            taken[u] = 1;
        }
    }
    model.asset.generator = "supermat " + std::to_string(SUPERMAT_VERSION_MAJOR) + "." + std::to_string(SUPERMAT_VERSION_MINOR) + "." +
                            std::to_string(SUPERMAT_VERSION_PATCH);

    /* how every image and buffer is stored: a .glb holds everything in its binary chunk; a .gltf keeps
       embedded images embedded (and stays self-contained when it was), files as files */
    Writer wr;
    const std::string base_name = outpath.substr(outpath.find_last_of('/') == std::string::npos ? 0 : outpath.find_last_of('/') + 1);
    wr.in_dir = dir_of(inpath); wr.out_dir = dir_of(outpath);
    wr.model = &model; wr.raw = &raw;
    wr.write.assign(model.images.size(), false);
    if (glb_out) {
        std::vector<unsigned char> bin;
        std::vector<size_t> at(model.buffers.size());
        for (size_t b = 0; b < model.buffers.size(); b++) {
            while (bin.size() % 4) bin.push_back(0);
            at[b] = bin.size();
            bin.insert(bin.end(), model.buffers[b].data.begin(), model.buffers[b].data.end());
        }
        for (tinygltf::BufferView &bv : model.bufferViews)
            if (bv.buffer >= 0 && bv.buffer < (int)at.size()) { bv.byteOffset += at[bv.buffer]; bv.buffer = 0; }
        for (size_t i = 0; i < model.images.size(); i++) {
            tinygltf::Image &img = model.images[i];
            if (img.bufferView >= 0) continue;
            if (raw.bytes[i].empty()) { std::fprintf(stderr, "supermat mesh: image %zu (%s) could not be read: it stays a reference\n", i, img.uri.c_str()); continue; }
            while (bin.size() % 4) bin.push_back(0);
            tinygltf::BufferView bv;
            bv.buffer = 0; bv.byteOffset = bin.size(); bv.byteLength = raw.bytes[i].size();
            bin.insert(bin.end(), raw.bytes[i].begin(), raw.bytes[i].end());
            model.bufferViews.push_back(bv);
            img.bufferView = (int)model.bufferViews.size() - 1;
            img.mimeType = mime_of(raw.bytes[i], img.mimeType);
            img.uri.clear();
        }
        while (bin.size() % 4) bin.push_back(0);
        tinygltf::Buffer one;
        one.data.swap(bin);
        model.buffers.assign(1, one);
    } else {
        for (size_t b = 0; b < model.buffers.size(); b++) { /* side files: plain names beside OUT */
            tinygltf::Buffer &buf = model.buffers[b];
            bool plain = !buf.uri.empty() && buf.uri.compare(0, 5, "data:") != 0 && buf.uri.find_first_of("/%\\:") == std::string::npos &&
                         uri_inside(buf.uri);
            if (!self_contained && !plain) buf.uri = stem + (b ? "_" + std::to_string(b) : std::string()) + ".bin";
        }
        for (size_t i = 0; i < model.images.size(); i++) {
            tinygltf::Image &img = model.images[i];
            if (img.bufferView >= 0) continue; /* stays in its buffer */
            if (raw.bytes[i].empty()) continue; /* a file that could not be read: the reference stays */
            if ((img.uri.empty() && !ours[i]) || (ours[i] && self_contained)) { /* embedded: a data URI */
                img.mimeType = mime_of(raw.bytes[i], img.mimeType);
                img.uri = "data:" + img.mimeType + ";base64," + base64(raw.bytes[i].data(), raw.bytes[i].size());
                continue;
            }
            if (!ours[i] && wr.in_dir == wr.out_dir && uri_inside(uri_decode(img.uri))) continue; /* already there */
            std::string dec = uri_decode(img.uri), leaf = dec.substr(dec.find_last_of('/') == std::string::npos ? 0 : dec.find_last_of('/') + 1);
            bool clash = dec == base_name || leaf.compare(0, 9, ".supermat") == 0; /* OUT itself, or the stage's own files */
            for (const tinygltf::Buffer &buf : model.buffers) clash = clash || uri_decode(buf.uri) == dec;
            if (!uri_inside(dec) || clash) /* outside the asset's folder (or taking OUT's or a buffer's name): copied beside OUT renamed */
                img.uri = stem + "_image" + std::to_string(i) + "." + ext_of_mime(mime_of(raw.bytes[i], img.mimeType));
            wr.write[i] = true;
        }
    }

    /* A --force run over an existing .gltf commits as a whole: a side file whose name holds other bytes in
       OUT's folder is written under a fresh name (NAME-1.ext, NAME-2.ext, ...: the first free or identical
       one), so no file the old .gltf refers to changes before the new .gltf replaces it in one rename; the
       old side files it no longer refers to are removed after (remove_unreferenced). */
    std::vector<std::string> anchors, old_refs;
    if (!glb_out && policy == 1) {
        std::vector<unsigned char> old = read_whole(outpath, true);
        if (!old.empty()) old_refs = gltf_refs(old);
        auto fresh = [&](const std::string &rel, const std::vector<unsigned char> &bytes) {
            anchors.push_back(rel);
            for (int k = 0; k < 1000; k++) {
                std::string cand = with_suffix(rel, k), p = wr.out_dir + "/" + cand;
                struct stat st;
                if (lstat(p.c_str(), &st) != 0) return cand;
                if (S_ISREG(st.st_mode) && read_whole(p, true) == bytes) return cand;
            }
            return rel;
        };
        if (!self_contained)
            for (tinygltf::Buffer &buf : model.buffers) {
                if (buf.uri.empty() || buf.uri.compare(0, 5, "data:") == 0) continue;
                std::string rel = uri_decode(buf.uri), c = fresh(rel, buf.data);
                if (c != rel) buf.uri = uri_encode(c);
            }
        for (size_t i = 0; i < model.images.size(); i++) {
            if (!wr.write[i]) continue;
            std::string rel = uri_decode(model.images[i].uri), c = fresh(rel, raw.bytes[i]);
            if (c != rel) model.images[i].uri = uri_encode(c);
        }
    }

    /* Everything is written into a staging folder beside OUT, read back (a truncated file -- full disk,
       size limit -- does not parse), then moved into place: OUT and its files appear complete or not at
       all. tinygltf does not check its own writes, hence the read-back. */
    tinygltf::TinyGLTF writer;
    writer.SetImageWriter(image_writer, &wr);
    std::string base = outpath.substr(outpath.find_last_of('/') == std::string::npos ? 0 : outpath.find_last_of('/') + 1);
    /* the stage: a new private folder (0700, created by this process with its marker, smio_stage_create), so
       nothing can be planted in it; the leftovers of killed runs in OUT's folder are removed first
       (smio_clean_stale: marked stages and temporary files of processes that are gone, nothing else) */
    char msg[1024] = "", stage_name[128];
    int out_fd = smio_dir_open(wr.out_dir.c_str(), "", 0, msg, sizeof msg);
    if (out_fd < 0) { std::fprintf(stderr, "supermat mesh: cannot write %s: %s\n", out, msg); return 1; }
    finish_pending(out_fd, wr.out_dir);
    smio_clean_stale(out_fd);
    if (smio_stage_create(out_fd, stage_name, sizeof stage_name) != 0) {
        std::fprintf(stderr, "supermat mesh: cannot write into %s: %s\n", wr.out_dir.c_str(), std::strerror(errno));
        close(out_fd);
        return 1;
    }
    wr.stage = wr.out_dir + "/" + stage_name;
    std::string staged = wr.stage + "/" + base;
    bool wok = writer.WriteGltfSceneToFile(&model, staged, false, self_contained && !glb_out, true, glb_out) && wr.failed.empty();
    if (wok) {
        tinygltf::Model back;
        std::string e, w;
        tinygltf::TinyGLTF reader;
        Raw raw_back;
        RefFs back_refs;
        back_refs.base = wr.stage;
        char *r = realpath(wr.stage.c_str(), nullptr);
        back_refs.real_dir = r ? r : wr.stage;
        std::free(r);
        reader.SetFsCallbacks(ref_fs(&back_refs));
        reader.SetImageLoader(raw_image_loader, &raw_back);
        std::vector<unsigned char> whole = read_whole(staged, true);
        wok = !whole.empty() && (glb_out ? reader.LoadBinaryFromMemory(&back, &e, &w, whole.data(), (unsigned int)whole.size(), wr.stage)
                                         : reader.LoadASCIIFromString(&back, &e, &w, (const char *)whole.data(), (unsigned int)whole.size(), wr.stage));
        for (size_t b = 0; wok && b < back.buffers.size() && b < model.buffers.size(); b++)
            wok = back.buffers[b].data.size() == model.buffers[b].data.size();
        raw_back.bytes.resize(back.images.size());
        for (size_t i = 0; wok && i < back.images.size() && i < model.images.size(); i++)
            if (ours[i]) wok = raw_back.bytes[i] == raw.bytes[i];
        if (!wok && wr.failed.empty()) wr.failed = std::string(out) + " (or a file beside it): the written asset does not read back complete (disk full?)";
    }
    std::vector<std::string> files;
    if (wok) list_files(wr.stage, "", files);
    /* the asset's own file last: its side files are in place before it refers to them */
    for (size_t k = 0; k + 1 < files.size(); k++)
        if (files[k] == base) { files.erase(files.begin() + (long)k); files.push_back(base); break; }
    files.erase(std::remove(files.begin(), files.end(), std::string(SMIO_STAGE_MARKER)), files.end());
    files.erase(std::remove(files.begin(), files.end(), std::string(PENDING_FILE)), files.end());
    for (const std::string &f : files) /* the policy for every file: OUT itself was checked before the work */
        if (f != base && exists_l(wr.out_dir + "/" + f) && policy != 1 &&
            read_whole(wr.out_dir + "/" + f, true) != read_whole(wr.stage + "/" + f, true)) { /* the same bytes: nothing lost */
            if (policy == 2) continue;
            std::fprintf(stderr, "supermat mesh: '%s/%s' exists and was not written by this run: --force replaces it, --skip-existing keeps it\n",
                         wr.out_dir.c_str(), f.c_str());
            wok = false;
            wr.failed = "-";
            break;
        }
    /* moved into place with renameat: OUT's sub-folders are opened (or made) without following a link, and
       a link at a file's name is replaced, never followed */
    int stage_fd = openat(out_fd, stage_name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (stage_fd < 0) wok = false;
    std::vector<std::string> owed; /* old side files of the replaced .gltf that the new one does not refer to */
    if (wok && !old_refs.empty()) {
        std::vector<unsigned char> now = read_whole(staged, true);
        std::vector<std::string> new_refs = gltf_refs(now);
        for (const std::string &r : old_refs)
            if (std::find(new_refs.begin(), new_refs.end(), r) == new_refs.end() && std::find(owed.begin(), owed.end(), r) == owed.end())
                for (const std::string &a : anchors)
                    if (in_family(r, a)) { owed.push_back(r); break; }
    }
    for (size_t k = 0; wok && k < files.size(); k++) {
        const std::string &f = files[k];
        if (f == base && !owed.empty()) { /* what is owed, kept in the stage until done (finish_pending) */
            std::string list = base + "\n";
            for (const std::string &o : owed) list += o + "\n";
            if (!write_file(wr.stage + "/" + PENDING_FILE, list.data(), list.size())) { wr.failed = wr.stage + "/" + PENDING_FILE; wok = false; break; }
        }
        std::string dst = wr.out_dir + "/" + f;
        if (f != base && policy == 2 && exists_l(dst)) continue;
        size_t sl = f.find_last_of('/');
        std::string sub = sl == std::string::npos ? "" : f.substr(0, sl), name = sl == std::string::npos ? f : f.substr(sl + 1);
        int src_fd = sub.empty() ? dup(stage_fd) : smio_dir_open(wr.stage.c_str(), sub.c_str(), 0, msg, sizeof msg);
        int dst_fd = src_fd < 0 ? -1 : sub.empty() ? dup(out_fd) : smio_dir_open(wr.out_dir.c_str(), sub.c_str(), 1, msg, sizeof msg);
        if (src_fd < 0 || dst_fd < 0) { wr.failed = dst + ": " + msg; wok = false; }
        else if (renameat(src_fd, name.c_str(), dst_fd, name.c_str()) != 0) { wr.failed = dst + ": " + std::strerror(errno); wok = false; }
        else (void)fsync(dst_fd);
        if (src_fd >= 0) close(src_fd);
        if (dst_fd >= 0) close(dst_fd);
    }
    if (stage_fd >= 0) close(stage_fd);
    if (wok && !owed.empty()) remove_unreferenced(out_fd, wr.out_dir, base, owed);
    smio_rmtree_at(out_fd, stage_name, 0);
    close(out_fd);
    if (!wok) {
        if (wr.failed != "-") std::fprintf(stderr, "supermat mesh: cannot write %s\n", wr.failed.empty() ? out : wr.failed.c_str());
        return 1;
    }
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    std::printf("%s: %d mesh(es), %d material(s), %u triangles (%u zero-area skipped), %llu chart texels, %.1f%% seen by a view; "
                "%.1f s, peak memory %.0f MB\n",
                out, meshes_baked, nout, st.triangles, st.triangles_degenerate, (unsigned long long)st.texels_chart,
                st.texels_chart ? 100.0 * st.texels_seen / st.texels_chart : 0.0, secs, ru.ru_maxrss / 1024.0);
    return 0;
}

/* `supermat mesh` as the supermat CLI runs it: policy (0 refuse existing outputs, 1 --force, 2
   --skip-existing) and allow_outside are its global options, which main() parsed; argv[0] "mesh" */
extern "C" int supermat_cli_mesh_global(int argc, char **argv, int policy, int allow_outside) {
    supermat_cli_mesh_opts o;
    const char *in = nullptr, *out = nullptr;
    o.policy = policy;
    o.allow_outside = allow_outside != 0;
    int rc = parse_mesh_opts(argc, argv, o, &in, &out);
    return rc >= 0 ? rc : run_mesh(o, in, out);
}
/* the standalone supermat_mesh (and the fuzzer): --force, --skip-existing, --allow-outside-refs in argv */
extern "C" int supermat_cli_mesh(int argc, char **argv) { return supermat_cli_mesh_global(argc, argv, 0, 0); }

/* `batch mesh`: the options once, before any asset (supermat_cli_mesh_opts_new, then one
   supermat_cli_mesh_opt_set per option of supermat_cli_mesh_bake_options, then supermat_cli_mesh_opts_check),
   then one run per asset, each writing over what the batch's journal says is not done (force) */
extern "C" supermat_cli_mesh_opts *supermat_cli_mesh_opts_new(void) {
    supermat_cli_mesh_opts *o = new (std::nothrow) supermat_cli_mesh_opts();
    if (!o) std::fprintf(stderr, "supermat: out of memory\n");
    return o;
}
/* 1: id is a bake option and its value is in o; -1: a usage message was printed; 0: id is not a bake option */
extern "C" int supermat_cli_mesh_opt_set(supermat_cli_mesh_opts *o, int id, const char *value) {
    if (id < MESH_O_MV || id > MESH_O_MAX_MEMORY) return 0;
    return mesh_opt_value(*o, id, value);
}
/* 0: the options go together; 2 after a usage message */
extern "C" int supermat_cli_mesh_opts_check(const supermat_cli_mesh_opts *o) { return mesh_opts_check(*o); }
/* the same from an argv (argv[0] "mesh", no IN OUT): 0 and *opts, else the exit status (2) after the message */
extern "C" int supermat_cli_mesh_opts_parse(int argc, char **argv, supermat_cli_mesh_opts **opts) {
    supermat_cli_mesh_opts *o = supermat_cli_mesh_opts_new();
    *opts = nullptr;
    if (!o) return 1;
    int rc = parse_mesh_opts(argc, argv, *o, nullptr, nullptr);
    if (rc >= 0) { delete o; return rc == 0 ? 2 : rc; }
    *opts = o;
    return 0;
}
extern "C" int supermat_cli_mesh_run(const supermat_cli_mesh_opts *opts, const char *in, const char *out, int force, int allow_outside) {
    supermat_cli_mesh_opts o = *opts;
    if (force) o.policy = 1;
    if (allow_outside) o.allow_outside = true;
    return run_mesh(o, in, out);
}
extern "C" void supermat_cli_mesh_opts_free(supermat_cli_mesh_opts *opts) { delete opts; }

#ifdef SUPERMAT_MESH_MAIN
/* standalone: no installed or source-tree default model; $SUPERMAT_MODEL when set */
extern "C" int supermat_cli_default_model(char *path, size_t cap, const char **from) {
    const char *env = std::getenv("SUPERMAT_MODEL");
    if (!env || !env[0] || std::strlen(env) >= cap) {
        std::fprintf(stderr, "supermat mesh: no model flags and no default model here (this standalone build knows only "
                             "$SUPERMAT_MODEL): give --mv-model, or use `supermat mesh`\n");
        return 0;
    }
    std::strcpy(path, env);
    *from = "$SUPERMAT_MODEL";
    return 1;
}
/* standalone: the named models from $SUPERMAT_MODEL_DIR only */
extern "C" int supermat_cli_named_model(const char *name, char *path, size_t cap) {
    static const char *const names[3][2] = {{"official-mv", "supermat_mv_official.safetensors"},
                                            {"official-refine-albedo", "supermat_refine_albedo_official.safetensors"},
                                            {"official-refine-rm", "supermat_refine_rm_official.safetensors"}};
    const char *dir = std::getenv("SUPERMAT_MODEL_DIR");
    for (int k = 0; k < 3; k++) {
        if (std::strcmp(name, names[k][0])) continue;
        if (!dir || !dir[0]) {
            std::fprintf(stderr, "supermat mesh: --model official: this standalone build finds the official networks only in "
                                 "$SUPERMAT_MODEL_DIR, which is not set; or use `supermat mesh`\n");
            return 0;
        }
        std::string p = std::string(dir) + "/" + names[k][1];
        if (access(p.c_str(), R_OK) != 0 || p.size() >= cap) {
            std::fprintf(stderr, "supermat mesh: --model official: %s is not there ($SUPERMAT_MODEL_DIR); `supermat download official` "
                                 "downloads and converts the official networks\n", p.c_str());
            return 0;
        }
        std::strcpy(path, p.c_str());
        return 1;
    }
    std::fprintf(stderr, "supermat mesh: '%s' is not a model name\n", name);
    return 0;
}
int main(int argc, char **argv) { return supermat_cli_mesh(argc, argv); }
#endif
