/* bake_gltf: PBR textures for a glTF asset with supermat_uv.h - the short version to copy.
 *
 *   bake_gltf MV.safetensors ALBEDO_REFINE.safetensors RM_REFINE.safetensors IN.gltf OUT.gltf
 *   bake_gltf --passthrough IN.gltf OUT.gltf            (no networks: tests the geometry)
 *
 * Takes the first primitive of the first mesh (node transforms ignored: see cli/mesh.cpp
 * for the complete tool), bakes 1024x1024 albedo and metallicRoughness textures and writes OUT with
 * its first material pointing at them. Build: c++ -O2 bake_gltf.cpp -ltinygltf -lstb -lpthread -lm
 */
#define SUPERMAT_IMPLEMENTATION
#define SUPERMAT_UV_IMPLEMENTATION
#include "supermat_uv.h"

#include <tiny_gltf.h>
#include <stb/stb_image_write.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

static supermat_model *load(const char *path, std::vector<unsigned char> &bytes) {
    FILE *f = std::fopen(path, "rb");
    if (!f) return nullptr;
    std::fseek(f, 0, SEEK_END);
    bytes.resize((size_t)std::ftell(f));
    std::fseek(f, 0, SEEK_SET);
    size_t got = std::fread(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    supermat_model_desc md;
    std::memset(&md, 0, sizeof md);
    md.data = bytes.data(); md.size = got;
    supermat_model *m = nullptr;
    supermat_error err;
    if (supermat_model_create(&md, &m, &err) != SUPERMAT_SUCCESS) std::fprintf(stderr, "%s: %s\n", path, err.message);
    return m;
}

/* float `count`-vector attribute of a primitive, tightly packed (assumes float accessors, as most assets) */
static std::vector<float> floats(const tinygltf::Model &m, int acc, int count) {
    const tinygltf::Accessor &a = m.accessors[acc];
    const tinygltf::BufferView &bv = m.bufferViews[a.bufferView];
    size_t stride = a.ByteStride(bv);
    std::vector<float> out(a.count * count);
    for (size_t i = 0; i < a.count; i++)
        std::memcpy(&out[i * count], &m.buffers[bv.buffer].data[bv.byteOffset + a.byteOffset + i * stride], 4 * count);
    return out;
}

int main(int argc, char **argv) {
    bool pass = argc == 4 && !std::strcmp(argv[1], "--passthrough");
    if (argc != 6 && !pass) { std::fprintf(stderr, "usage: bake_gltf MV BC_REFINE RM_REFINE IN.gltf OUT.gltf\n"); return 2; }
    std::string in = argv[argc - 2], out = argv[argc - 1];
    tinygltf::Model model;
    tinygltf::TinyGLTF gltf;
    std::string err, warn;
    if (!gltf.LoadASCIIFromFile(&model, &err, &warn, in) || model.meshes.empty()) { std::fprintf(stderr, "%s: %s\n", in.c_str(), err.c_str()); return 1; }
    tinygltf::Primitive &prim = model.meshes[0].primitives[0];
    if (!prim.attributes.count("TEXCOORD_0")) { std::fprintf(stderr, "the mesh has no UVs\n"); return 1; }

    /* the mesh: glTF is Y up, supermat_uv.h wants Z up: (x, y, z) -> (x, -z, y) */
    std::vector<float> pos = floats(model, prim.attributes["POSITION"], 3), uv = floats(model, prim.attributes["TEXCOORD_0"], 2);
    for (size_t i = 0; i < pos.size(); i += 3) { float y = pos[i + 1]; pos[i + 1] = -pos[i + 2]; pos[i + 2] = y; }
    std::vector<uint32_t> idx;
    const tinygltf::Accessor &ia = model.accessors[prim.indices];
    const tinygltf::BufferView &ibv = model.bufferViews[ia.bufferView];
    const unsigned char *ib = &model.buffers[ibv.buffer].data[ibv.byteOffset + ia.byteOffset];
    for (size_t i = 0; i < ia.count; i++)
        idx.push_back(ia.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT ? ((const uint32_t *)ib)[i]
                      : ia.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? ((const uint16_t *)ib)[i] : ib[i]);

    supermat_uv_part part;
    std::memset(&part, 0, sizeof part);
    part.positions = pos.data(); part.uvs = uv.data(); part.vertex_count = (uint32_t)(pos.size() / 3);
    part.indices = idx.data(); part.index_count = (uint32_t)idx.size();
    tinygltf::Material &mat = model.materials.at(prim.material >= 0 ? prim.material : 0);
    if (mat.pbrMetallicRoughness.baseColorTexture.index >= 0) { /* tinygltf decoded it as 8-bit RGBA */
        tinygltf::Image &im = model.images[model.textures[mat.pbrMetallicRoughness.baseColorTexture.index].source];
        part.base_color.pixels = im.image.data();
        part.base_color.width = im.width; part.base_color.height = im.height; part.base_color.channels = im.component;
    }

    std::vector<unsigned char> f1, f2, f3;
    supermat_uv_bake_desc bd;
    std::memset(&bd, 0, sizeof bd);
    bd.parts = &part; bd.part_count = 1;
    bd.passthrough = pass;
    if (!pass) {
        bd.mv_model = load(argv[1], f1); bd.albedo_refine_model = load(argv[2], f2); bd.rm_refine_model = load(argv[3], f3);
        if (!bd.mv_model || !bd.albedo_refine_model || !bd.rm_refine_model) return 1;
    }
    const int N = 1024; /* the default texture size */
    std::vector<unsigned char> albedo(N * N * 3), mr(N * N * 3);
    supermat_uv_output o;
    std::memset(&o, 0, sizeof o);
    o.base_color.pixels = albedo.data(); o.base_color.channels = 3;
    o.metallic_roughness.pixels = mr.data(); o.metallic_roughness.channels = 3;
    supermat_error e;
    supermat_result r = supermat_uv_bake(&bd, &o, nullptr, &e);
    supermat_model_destroy((supermat_model *)bd.mv_model);
    supermat_model_destroy((supermat_model *)bd.albedo_refine_model);
    supermat_model_destroy((supermat_model *)bd.rm_refine_model);
    if (r != SUPERMAT_SUCCESS) { std::fprintf(stderr, "bake: %s\n", e.message); return 1; }

    /* the textures next to OUT, and the material pointing at them */
    std::string dir = out.find('/') == std::string::npos ? "." : out.substr(0, out.find_last_of('/'));
    stbi_write_png((dir + "/baked_baseColor.png").c_str(), N, N, 3, albedo.data(), N * 3);
    stbi_write_png((dir + "/baked_metallicRoughness.png").c_str(), N, N, 3, mr.data(), N * 3);
    const char *names[2] = {"baked_baseColor.png", "baked_metallicRoughness.png"};
    for (int k = 0; k < 2; k++) {
        tinygltf::Image im;
        im.uri = names[k];
        model.images.push_back(im);
        tinygltf::Texture t;
        t.source = (int)model.images.size() - 1;
        model.textures.push_back(t);
    }
    int n = (int)model.textures.size();
    mat.pbrMetallicRoughness.baseColorTexture.index = n - 2;
    mat.pbrMetallicRoughness.metallicRoughnessTexture.index = n - 1;
    mat.pbrMetallicRoughness.baseColorFactor = {1, 1, 1, 1};
    mat.pbrMetallicRoughness.metallicFactor = mat.pbrMetallicRoughness.roughnessFactor = 1;
    for (tinygltf::Image &im : model.images) im.image.clear(); /* keep every image file as it is */
    gltf.SetImageWriter([](const std::string *, const std::string *, const tinygltf::Image *, bool, std::string *, void *) { return false; }, nullptr);
    if (!gltf.WriteGltfSceneToFile(&model, out, false, false, true, false)) { std::fprintf(stderr, "cannot write %s\n", out.c_str()); return 1; }
    std::printf("wrote %s with %s/baked_baseColor.png and baked_metallicRoughness.png\n", out.c_str(), dir.c_str());
    return 0;
}
