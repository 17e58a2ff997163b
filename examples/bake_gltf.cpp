/* bake_gltf: PBR textures for a glTF asset with supermat_uv.h - the short version to copy.
 *
 *   bake_gltf MV.safetensors IN.gltf OUT.gltf                  (the view model alone: `supermat mesh`)
 *   bake_gltf MV.safetensors BC_REFINE.safetensors RM_REFINE.safetensors IN.gltf OUT.gltf
 *                                                              (and the two UV-refine models: `supermat mesh --refine`)
 *   bake_gltf --passthrough IN.gltf OUT.gltf                   (no networks: tests the geometry)
 *
 * Takes the first primitive of the first mesh with its normals and its material's base colour (texture,
 * factor, sampler wrap), bakes 1024x1024 albedo and metallicRoughness textures and writes OUT with that
 * material pointing at them. Every bake desc field it does not need stays 0: the networks run as their
 * model files record (work sizes, the detail step), so for a mesh without node transform and an opaque
 * material this writes the textures `supermat mesh` writes with the same models, pixel for pixel (ctest
 * uv_bake_parity). cli/mesh.cpp is the complete tool: node transforms, every mesh and material, alpha,
 * texCoord sets, KHR_texture_transform.
 * Build: c++ -O2 -ffp-contract=off bake_gltf.cpp -ltinygltf -lstb -lpthread -lm
 * (-ffp-contract=off as the CLI builds supermat.h: g++ and clang++ fuse multiply-adds otherwise, a few values move by 1/255)
 */
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"

#include <tiny_gltf.h>
#include <stb/stb_image_write.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

/* a model file read into `bytes` (which the model borrows: keep them until it is destroyed); NULL after a message */
static supermat_model *load(const char *path, std::vector<unsigned char> &bytes) {
    FILE *f = std::fopen(path, "rb");
    long n = -1;
    if (f && std::fseek(f, 0, SEEK_END) == 0 && (n = std::ftell(f)) > 0 && std::fseek(f, 0, SEEK_SET) == 0) {
        bytes.resize((size_t)n);
        if (std::fread(bytes.data(), 1, bytes.size(), f) != bytes.size()) n = -1;
    }
    if (!f || n <= 0) {
        std::fprintf(stderr, "%s: cannot read it%s%s\n", path, f ? "" : ": ", f ? "" : std::strerror(errno));
        if (f) std::fclose(f);
        return nullptr;
    }
    std::fclose(f);
    supermat_model_desc md;
    std::memset(&md, 0, sizeof md);
    md.data = bytes.data(); md.size = bytes.size();
    supermat_model *m = nullptr;
    supermat_error err;
    if (supermat_model_create(&md, &m, &err) != SUPERMAT_SUCCESS) std::fprintf(stderr, "%s: %s\n", path, err.message);
    return m;
}

/* a float `count`-vector attribute, tightly packed; empty when it is not one (this example reads float accessors only) */
static std::vector<float> floats(const tinygltf::Model &m, int acc, int count) {
    if (acc < 0 || acc >= (int)m.accessors.size()) return {};
    const tinygltf::Accessor &a = m.accessors[acc];
    if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT || tinygltf::GetNumComponentsInType(a.type) != count ||
        a.bufferView < 0 || a.bufferView >= (int)m.bufferViews.size() || a.count == 0) return {};
    const tinygltf::BufferView &bv = m.bufferViews[a.bufferView];
    size_t stride = a.ByteStride(bv), start = bv.byteOffset + a.byteOffset;
    if (start + (a.count - 1) * stride + 4 * count > m.buffers[bv.buffer].data.size()) return {};
    std::vector<float> out(a.count * count);
    for (size_t i = 0; i < a.count; i++) std::memcpy(&out[i * count], &m.buffers[bv.buffer].data[start + i * stride], 4 * count);
    return out;
}

/* glTF is Y up, supermat_uv.h wants Z up: (x, y, z) -> (x, -z, y) */
static void z_up(std::vector<float> &v) {
    for (size_t i = 0; i + 2 < v.size(); i += 3) { float y = v[i + 1]; v[i + 1] = -v[i + 2]; v[i + 2] = y; }
}

static supermat_uv_wrap wrap_of(int gl) {
    return gl == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE ? SUPERMAT_UV_WRAP_CLAMP
         : gl == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? SUPERMAT_UV_WRAP_MIRROR : SUPERMAT_UV_WRAP_REPEAT;
}

int main(int argc, char **argv) {
    bool pass = argc == 4 && !std::strcmp(argv[1], "--passthrough");
    if (!pass && argc != 4 && argc != 6) {
        std::fprintf(stderr, "usage: bake_gltf MV [BC_REFINE RM_REFINE] IN.gltf OUT.gltf | bake_gltf --passthrough IN.gltf OUT.gltf\n");
        return 2;
    }
    std::string in = argv[argc - 2], out = argv[argc - 1];
    tinygltf::Model model;
    tinygltf::TinyGLTF gltf;
    std::string err, warn;
    if (!gltf.LoadASCIIFromFile(&model, &err, &warn, in)) { std::fprintf(stderr, "%s: %s\n", in.c_str(), err.c_str()); return 1; }
    if (model.meshes.empty() || model.meshes[0].primitives.empty()) { std::fprintf(stderr, "%s: no mesh\n", in.c_str()); return 1; }
    tinygltf::Primitive &prim = model.meshes[0].primitives[0];
    auto attr = [&](const char *name) { return prim.attributes.count(name) ? prim.attributes[name] : -1; };

    /* the mesh */
    std::vector<float> pos = floats(model, attr("POSITION"), 3), uv = floats(model, attr("TEXCOORD_0"), 2),
                       nrm = floats(model, attr("NORMAL"), 3);
    if (pos.empty() || uv.size() / 2 != pos.size() / 3) { std::fprintf(stderr, "%s: the mesh needs float positions and UVs\n", in.c_str()); return 1; }
    z_up(pos); z_up(nrm);
    std::vector<uint32_t> idx;
    if (prim.indices < 0)
        for (uint32_t i = 0; i < pos.size() / 3; i++) idx.push_back(i);
    else { /* 8, 16 or 32-bit indices, tightly packed */
        const tinygltf::Accessor &ia = model.accessors[prim.indices]; /* tinygltf checked it and its bufferView */
        int size = tinygltf::GetComponentSizeInBytes(ia.componentType);
        if (ia.bufferView < 0 || size < 1 || ia.type != TINYGLTF_TYPE_SCALAR) { std::fprintf(stderr, "%s: unsupported indices\n", in.c_str()); return 1; }
        const tinygltf::BufferView &ibv = model.bufferViews[ia.bufferView];
        const std::vector<unsigned char> &buf = model.buffers[ibv.buffer].data;
        if (ibv.byteOffset + ia.byteOffset + ia.count * size > buf.size()) { std::fprintf(stderr, "%s: indices past their buffer\n", in.c_str()); return 1; }
        const unsigned char *ib = &buf[ibv.byteOffset + ia.byteOffset];
        for (size_t i = 0; i < ia.count; i++)
            idx.push_back(size == 4 ? ((const uint32_t *)ib)[i] : size == 2 ? ((const uint16_t *)ib)[i] : ib[i]);
    }
    supermat_uv_part part;
    std::memset(&part, 0, sizeof part);
    part.positions = pos.data(); part.uvs = uv.data(); part.vertex_count = (uint32_t)(pos.size() / 3);
    part.normals = nrm.size() == pos.size() ? nrm.data() : nullptr;
    part.indices = idx.data(); part.index_count = (uint32_t)idx.size();

    /* its material's base colour: factor, texture (tinygltf decoded it: 8 or 16 bits, RGBA), sampler wrap */
    if (prim.material < 0) { prim.material = (int)model.materials.size(); model.materials.emplace_back(); }
    if (prim.material >= (int)model.materials.size()) { std::fprintf(stderr, "%s: material %d does not exist\n", in.c_str(), prim.material); return 1; }
    tinygltf::Material &mat = model.materials[prim.material];
    float factor[4];
    for (int k = 0; k < 4; k++) factor[k] = k < (int)mat.pbrMetallicRoughness.baseColorFactor.size() ? (float)mat.pbrMetallicRoughness.baseColorFactor[k] : 1.0f;
    part.base_color_factor = factor;
    std::vector<unsigned char> tex;
    int ti = mat.pbrMetallicRoughness.baseColorTexture.index;
    int src = ti >= 0 && ti < (int)model.textures.size() ? model.textures[ti].source : -1;
    if (src >= 0 && src < (int)model.images.size() && !model.images[src].image.empty()) {
        const tinygltf::Texture &t = model.textures[ti];
        const tinygltf::Image &im = model.images[src];
        tex = im.image;
        if (im.bits == 16) /* to 8 bits, as stb_image does */
            for (size_t i = 0; i < tex.size() / 2; i++) tex[i] = (unsigned char)(((const uint16_t *)im.image.data())[i] >> 8);
        part.base_color.pixels = tex.data();
        part.base_color.width = im.width; part.base_color.height = im.height; part.base_color.channels = im.component;
        if (t.sampler >= 0 && t.sampler < (int)model.samplers.size()) {
            part.wrap_u = wrap_of(model.samplers[t.sampler].wrapS);
            part.wrap_v = wrap_of(model.samplers[t.sampler].wrapT);
        }
    }

    /* the models; every other bake desc field stays 0: what the model files record */
    std::vector<unsigned char> f1, f2, f3;
    supermat_uv_bake_desc bd;
    std::memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1;
    bd.passthrough = pass;
    if (!pass) {
        bd.mv_model = load(argv[1], f1);
        if (argc == 6) { bd.albedo_refine_model = load(argv[2], f2); bd.rm_refine_model = load(argv[3], f3); }
    }
    bool loaded = pass || (bd.mv_model && (argc == 4 || (bd.albedo_refine_model && bd.rm_refine_model)));
    const int N = 1024; /* the default texture size */
    std::vector<unsigned char> albedo(N * N * 3), mr(N * N * 3);
    supermat_uv_output o;
    std::memset(&o, 0, sizeof o);
    o.base_color.pixels = albedo.data(); o.base_color.channels = 3;
    o.metallic_roughness.pixels = mr.data(); o.metallic_roughness.channels = 3;
    supermat_error e;
    supermat_result r = loaded ? supermat_uv_bake(&bd, &o, nullptr, &e) : SUPERMAT_ERROR_INVALID_ARGUMENT;
    supermat_model_destroy((supermat_model *)bd.mv_model);
    supermat_model_destroy((supermat_model *)bd.albedo_refine_model);
    supermat_model_destroy((supermat_model *)bd.rm_refine_model);
    if (!loaded) return 1; /* load() said why */
    if (r != SUPERMAT_SUCCESS) { std::fprintf(stderr, "bake: %s\n", e.message); return 1; }

    /* the textures next to OUT, and the material pointing at them */
    std::string dir = out.find('/') == std::string::npos ? "." : out.substr(0, out.find_last_of('/'));
    const char *names[2] = {"baked_baseColor.png", "baked_metallicRoughness.png"};
    const std::vector<unsigned char> *pixels[2] = {&albedo, &mr};
    for (int k = 0; k < 2; k++) {
        std::string path = dir + "/" + names[k];
        if (!stbi_write_png(path.c_str(), N, N, 3, pixels[k]->data(), N * 3)) { std::fprintf(stderr, "cannot write %s\n", path.c_str()); return 1; }
        tinygltf::Image im;
        im.uri = names[k];
        model.images.push_back(im);
        tinygltf::Texture t;
        t.source = (int)model.images.size() - 1;
        model.textures.push_back(t);
    }
    int n = (int)model.textures.size();
    mat.pbrMetallicRoughness.baseColorTexture = tinygltf::TextureInfo();
    mat.pbrMetallicRoughness.baseColorTexture.index = n - 2;
    mat.pbrMetallicRoughness.metallicRoughnessTexture = tinygltf::TextureInfo();
    mat.pbrMetallicRoughness.metallicRoughnessTexture.index = n - 1;
    mat.pbrMetallicRoughness.baseColorFactor = {1, 1, 1, 1};
    mat.pbrMetallicRoughness.metallicFactor = mat.pbrMetallicRoughness.roughnessFactor = 1;
    for (tinygltf::Image &im : model.images) im.image.clear(); /* keep every image file as it is */
    gltf.SetImageWriter([](const std::string *, const std::string *, const tinygltf::Image *, bool, std::string *, void *) { return false; }, nullptr);
    if (!gltf.WriteGltfSceneToFile(&model, out, false, false, true, false)) { std::fprintf(stderr, "cannot write %s\n", out.c_str()); return 1; }
    std::printf("wrote %s with %s/%s and %s\n", out.c_str(), dir.c_str(), names[0], names[1]);
    return 0;
}
