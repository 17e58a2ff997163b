/* Test of `supermat mesh` (build/supermat_mesh): writes a textured cube glTF (.gltf + .bin + .png, with a
   node transform), bakes it with --passthrough and compares OUT's baseColor texture with the source
   texture on the texels mask.png marks as seen; then runs the full path with the tiny models.
   usage: test_mesh_cli SUPERMAT_MESH OUTDIR [TINY_MV TINY_UV] */
#include "uv/uv_meshes.h"

#include <tiny_gltf.h>
#include <OpenImageIO/imageio.h>

#include <dirent.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>


static std::vector<unsigned char> slurp(const std::string &path) {
    std::vector<unsigned char> b;
    FILE *f = std::fopen(path.c_str(), "rb");
    unsigned char buf[65536];
    size_t n;
    if (!f) return b;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) b.insert(b.end(), buf, buf + n);
    std::fclose(f);
    return b;
}
static std::string slurp_str(const std::string &path) {
    std::vector<unsigned char> b = slurp(path);
    return std::string(b.begin(), b.end());
}

static bool read_image(const std::string &path, std::vector<unsigned char> &px, int &w, int &h, int &c) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) return false;
    const OIIO::ImageSpec &s = in->spec();
    w = s.width; h = s.height; c = s.nchannels;
    px.resize((size_t)w * h * c);
    bool ok = in->read_image(0, 0, 0, c, OIIO::TypeDesc::UINT8, px.data());
    in->close();
    return ok;
}

/* the cube of uv_meshes.h in glTF's frame (Y up: (X, Y, Z)_Z-up -> (X, Z, -Y)) */
static void write_cube(const std::string &dir, int ts) {
    UvMesh m = uv_cube();
    std::vector<unsigned char> bin;
    auto put = [&bin](const void *p, size_t n) { const unsigned char *b = (const unsigned char *)p; bin.insert(bin.end(), b, b + n); };
    for (size_t i = 0; i < m.pos.size(); i += 3) { float v[3] = {m.pos[i], m.pos[i + 2], -m.pos[i + 1]}; put(v, 12); }
    size_t nrm_off = bin.size();
    for (size_t i = 0; i < m.nrm.size(); i += 3) { float v[3] = {m.nrm[i], m.nrm[i + 2], -m.nrm[i + 1]}; put(v, 12); }
    size_t uv_off = bin.size();
    put(m.uv.data(), m.uv.size() * 4);
    size_t idx_off = bin.size();
    for (uint32_t i : m.idx) { uint16_t s = (uint16_t)i; put(&s, 2); }
    FILE *f = std::fopen((dir + "/cube.bin").c_str(), "wb");
    std::fwrite(bin.data(), 1, bin.size(), f);
    std::fclose(f);
    char js[4096];
    std::snprintf(js, sizeof js,
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\n"
        " \"nodes\":[{\"children\":[1],\"translation\":[3,-2,5]},{\"mesh\":0,\"scale\":[2,2,2],\"rotation\":[0,0.7071068,0,0.7071068]}],\n"
        " \"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":3,\"material\":0}]}],\n"
        " \"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},\"metallicFactor\":0.0}}],\n"
        " \"textures\":[{\"source\":0,\"sampler\":0}],\"samplers\":[{\"wrapS\":10497,\"wrapT\":10497}],\n"
        " \"images\":[{\"uri\":\"cube_texture.png\"}],\n"
        " \"buffers\":[{\"uri\":\"cube.bin\",\"byteLength\":%zu}],\n"
        " \"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},\n"
        "   {\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],\n"
        " \"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\",\"min\":[-1,-1,-1],\"max\":[1,1,1]},\n"
        "   {\"bufferView\":1,\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\"},\n"
        "   {\"bufferView\":2,\"componentType\":5126,\"count\":%u,\"type\":\"VEC2\"},\n"
        "   {\"bufferView\":3,\"componentType\":5123,\"count\":%zu,\"type\":\"SCALAR\"}]}\n",
        bin.size(), nrm_off, nrm_off, uv_off - nrm_off, uv_off, idx_off - uv_off, idx_off, bin.size() - idx_off,
        m.nv(), m.nv(), m.nv(), m.idx.size());
    f = std::fopen((dir + "/cube.gltf").c_str(), "w");
    std::fputs(js, f);
    std::fclose(f);
    std::vector<unsigned char> tex = uv_smooth_texture(ts, ts);
    auto out = OIIO::ImageOutput::create(dir + "/cube_texture.png");
    out->open(dir + "/cube_texture.png", OIIO::ImageSpec(ts, ts, 3, OIIO::TypeDesc::UINT8));
    out->write_image(OIIO::TypeDesc::UINT8, tex.data());
    out->close();
}

/* the baseColor and metallicRoughness image files of OUT's first material */
static bool out_textures(const std::string &gltf, std::string *bc, std::string *mr) {
    tinygltf::Model m;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    if (!loader.LoadASCIIFromFile(&m, &err, &warn, gltf)) { std::printf("%s\n", err.c_str()); return false; }
    if (m.materials.empty()) return false;
    const tinygltf::PbrMetallicRoughness &p = m.materials[0].pbrMetallicRoughness;
    if (p.baseColorTexture.index < 0 || p.metallicRoughnessTexture.index < 0) return false;
    std::string dir = gltf.substr(0, gltf.find_last_of('/'));
    *bc = dir + "/" + m.images[m.textures[p.baseColorTexture.index].source].uri;
    *mr = dir + "/" + m.images[m.textures[p.metallicRoughnessTexture.index].source].uri;
    return p.metallicFactor == 1.0 && p.roughnessFactor == 1.0;
}

int main(int argc, char **argv) {
    if (argc < 3) { std::printf("usage: test_mesh_cli SUPERMAT_MESH OUTDIR [TINY_MV TINY_UV]\n"); return 2; }
    std::string exe = argv[1], dir = argv[2];
    mkdir(dir.c_str(), 0777);
    int ts = 256;
    write_cube(dir, ts);
    /* ---- passthrough round trip ---- */
    std::string cmd = exe + " --passthrough --size 256 --views-size 512 --debug-dir " + dir + "/debug " + dir + "/cube.gltf " + dir + "/out/cube_baked.gltf";
    std::system(("rm -rf '" + dir + "/out' '" + dir + "/out_limited'").c_str()); /* this test's own folders: a fresh start */
    mkdir((dir + "/out").c_str(), 0777);
    int rc = std::system(cmd.c_str());
    CHECK(rc == 0, "%s failed (%d)", cmd.c_str(), rc);
    std::string bc, mr;
    CHECK(out_textures(dir + "/out/cube_baked.gltf", &bc, &mr), "OUT has no baked textures with factors 1");
    std::vector<unsigned char> src, outp, mask, pos, mrp;
    int w, h, c, w2, h2, c2, w3, h3, c3, w4, h4, c4, w5, h5, c5;
    bool ok = read_image(dir + "/cube_texture.png", src, w, h, c) && read_image(bc, outp, w2, h2, c2) &&
              read_image(dir + "/debug/mask.png", mask, w3, h3, c3) && read_image(dir + "/debug/position.png", pos, w4, h4, c4) &&
              read_image(mr, mrp, w5, h5, c5);
    CHECK(ok && w2 == ts && h2 == ts && c2 >= 3 && w3 == ts && c3 == 1 && w4 == ts && c4 == 3, "cannot read the images");
    if (ok) {
        double se = 0;
        long seen = 0, chart = 0;
        bool mr_ok = true;
        for (int i = 0; i < ts * ts; i++) {
            bool on_chart = !(pos[i * 3] == 127 && pos[i * 3 + 1] == 127 && pos[i * 3 + 2] == 127);
            chart += on_chart;
            if (mrp[i * c5 + 1] != 128 || mrp[i * c5 + 2] != 0) mr_ok = false;
            if (mask[i] == 0) continue;
            seen++;
            for (int k = 0; k < 3; k++) { double d = (outp[i * c2 + k] - src[i * 3 + k]) / 255.0; se += d * d; }
        }
        double mse = se / (3.0 * seen), psnr = mse > 0 ? 10 * std::log10(1 / mse) : 99;
        std::printf("supermat mesh --passthrough on a textured cube glTF (node transform, 256 texture, 512 views): "
                    "PSNR %.2f dB over %ld seen texels, coverage %.2f%% of %ld chart texels\n", psnr, seen, 100.0 * seen / chart, chart);
        CHECK(psnr >= 35 && seen == chart && chart > 0.5 * ts * ts, "PSNR %g, seen %ld of %ld", psnr, seen, chart);
        CHECK(mr_ok, "metallicRoughness is not (., 0.5, 0)");
        const char *dbg[] = {"view_0", "view_5", "pred_albedo_0", "pred_rm_3", "partial_albedo", "partial_rm"};
        for (const char *d : dbg) {
            struct stat sb;
            CHECK(stat((dir + "/debug/" + d + ".png").c_str(), &sb) == 0, "no debug image %s", d);
        }
    }
    /* ---- errors: no UVs ---- */
    {
        FILE *f = std::fopen((dir + "/cube.gltf").c_str(), "r");
        std::string js;
        char buf[4096];
        size_t n;
        while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) js.append(buf, n);
        std::fclose(f);
        size_t p = js.find(",\"TEXCOORD_0\":2");
        if (p != std::string::npos) js.erase(p, std::strlen(",\"TEXCOORD_0\":2"));
        f = std::fopen((dir + "/nouv.gltf").c_str(), "w");
        std::fputs(js.c_str(), f);
        std::fclose(f);
        rc = std::system((exe + " --passthrough --size 64 --views-size 64 " + dir + "/nouv.gltf " + dir + "/out/nouv.gltf 2> " + dir + "/nouv.txt").c_str());
        std::string msg;
        f = std::fopen((dir + "/nouv.txt").c_str(), "r");
        if (f) { while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) msg.append(buf, n); std::fclose(f); }
        CHECK(rc != 0 && msg.find("needs UVs") != std::string::npos, "no UVs: rc %d, %s", rc, msg.c_str());
    }
    /* ---- a GLB whose BIN chunk claims 8 bytes more than the file holds (within the header's length as
       Debian's tinygltf 2.7 counts it, which leaves out the chunk header): refused before tinygltf reads it ---- */
    {
        std::string js = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":16}]}";
        while (js.size() % 4) js += ' ';
        std::vector<unsigned char> g;
        auto u32 = [&g](uint32_t v) { for (int i = 0; i < 4; i++) g.push_back((unsigned char)(v >> (8 * i))); };
        g.insert(g.end(), {'g', 'l', 'T', 'F'});
        u32(2);
        u32((uint32_t)(20 + js.size() + 16)); /* = the file's size: 8 bytes of chunk header + 8 of data follow the JSON */
        u32((uint32_t)js.size());
        u32(0x4E4F534Au);
        g.insert(g.end(), js.begin(), js.end());
        u32(16); /* the BIN chunk claims 16 bytes ... */
        u32(0x004E4942u);
        for (int i = 0; i < 8; i++) g.push_back(0); /* ... and holds 8 */
        FILE *f = std::fopen((dir + "/short_bin.glb").c_str(), "wb");
        std::fwrite(g.data(), 1, g.size(), f);
        std::fclose(f);
        rc = std::system((exe + " --passthrough " + dir + "/short_bin.glb " + dir + "/out/short_bin.glb 2> " + dir + "/short_bin.txt").c_str());
        std::string msg = slurp_str(dir + "/short_bin.txt");
        CHECK(rc != -1 && WIFEXITED(rc) && WEXITSTATUS(rc) == 1 && msg.find("runs past the GLB") != std::string::npos,
              "a GLB with a short BIN chunk: rc %d, %s", rc, msg.c_str());
        struct stat st;
        CHECK(::stat((dir + "/out/short_bin.glb").c_str(), &st) != 0, "a GLB with a short BIN chunk: an output was written");
    }
    /* ---- outputs: the overwrite policy, and a write that fails leaves nothing ---- */
    {
        std::string again = exe + " --passthrough --size 64 --views-size 64 " + dir + "/cube.gltf " + dir + "/out/cube_baked.gltf";
        std::vector<unsigned char> before = slurp(dir + "/out/cube_baked.gltf"), tex = slurp(dir + "/out/cube_baked_baseColor.png");
        rc = std::system((again + " 2> " + dir + "/again.txt").c_str());
        std::string msg = slurp_str(dir + "/again.txt");
        CHECK(rc != 0 && msg.find("cube_baked.gltf' exists and was not written by this run") != std::string::npos,
              "OUT exists: rc %d, %s", rc, msg.c_str());
        CHECK(slurp(dir + "/out/cube_baked.gltf") == before && slurp(dir + "/out/cube_baked_baseColor.png") == tex && !tex.empty(),
              "OUT exists: it or its texture was changed");
        rc = std::system((again + " --skip-existing 2> " + dir + "/again.txt").c_str());
        CHECK(rc == 0 && slurp(dir + "/out/cube_baked.gltf") == before, "--skip-existing: rc %d, or OUT changed", rc);
        rc = std::system((again + " --force").c_str());
        CHECK(rc == 0 && slurp(dir + "/out/cube_baked_baseColor.png") != tex, "--force: rc %d, or the texture (now 64x64) unchanged", rc);
        /* a 16 KiB file size limit: the 64x64 textures fit, the .bin / .gltf of a 1024 texture do not */
        mkdir((dir + "/out_limited").c_str(), 0777);
        rc = std::system(("sh -c 'trap \"\" XFSZ; ulimit -f 16; exec " + exe + " --passthrough --size 1024 --views-size 64 " + dir +
                          "/cube.gltf " + dir + "/out_limited/cube.gltf' 2> " + dir + "/limited.txt").c_str());
        msg = slurp_str(dir + "/limited.txt");
        std::vector<std::string> left;
        struct dirent *e_;
        DIR *d = opendir((dir + "/out_limited").c_str());
        while (d && (e_ = readdir(d)) != nullptr) if (std::strcmp(e_->d_name, ".") && std::strcmp(e_->d_name, "..")) left.push_back(e_->d_name);
        if (d) closedir(d);
        CHECK(rc != 0 && msg.find("cannot write") != std::string::npos, "a failed write: rc %d, %s", rc, msg.c_str());
        CHECK(left.empty(), "a failed write left %zu file(s) in out_limited/, e.g. %s", left.size(), left.empty() ? "" : left[0].c_str());
    }
    /* ---- --max-memory: a bake over the cap is refused before it allocates, nothing is written ---- */
    {
        std::string capped = exe + " --passthrough --size 1024 --views-size 512 " + dir + "/cube.gltf " + dir + "/out/capped.gltf";
        rc = std::system((capped + " --max-memory 8M 2> " + dir + "/capped.txt").c_str());
        std::string msg = slurp_str(dir + "/capped.txt");
        struct stat sb;
        CHECK(rc != 0 && msg.find("more than max_memory = 8388608 bytes") != std::string::npos && msg.find("needs") != std::string::npos &&
              stat((dir + "/out/capped.gltf").c_str(), &sb) != 0, "--max-memory 8M: rc %d, %s", rc, msg.c_str());
        rc = std::system((capped + " --max-memory lots 2> " + dir + "/capped.txt").c_str());
        msg = slurp_str(dir + "/capped.txt");
        CHECK(rc != 0 && msg.find("is not a size") != std::string::npos, "--max-memory lots: rc %d, %s", rc, msg.c_str());
        rc = std::system((capped + " --max-memory 4G").c_str());
        CHECK(rc == 0 && stat((dir + "/out/capped.gltf").c_str(), &sb) == 0, "--max-memory 4G: rc %d", rc);
    }
    /* ---- the full path with the tiny models ---- */
    if (argc > 4) {
        cmd = exe + " --mv-model " + argv[3] + " --albedo-refine " + argv[4] + " --rm-refine " + argv[4] +
              " --size 128 --views-size 64 --work-size native " + dir + "/cube.gltf " + dir + "/out/cube_full.gltf";
        rc = std::system(cmd.c_str());
        CHECK(rc == 0, "%s failed (%d)", cmd.c_str(), rc);
        CHECK(out_textures(dir + "/out/cube_full.gltf", &bc, &mr) && read_image(bc, outp, w, h, c) && w == 128,
              "the full path wrote no textures");
        /* a cap under the models' own size: the first model is refused while it is created */
        rc = std::system((cmd + "_capped --max-memory 64K 2> " + dir + "/capped_models.txt").c_str());
        std::string msg = slurp_str(dir + "/capped_models.txt");
        CHECK(rc != 0 && msg.find("max_memory") != std::string::npos, "models over --max-memory 64K: rc %d, %s", rc, msg.c_str());
    }
    std::printf("%d passed, %d failed\n", g_pass, g_fail);
    return g_fail ? 1 : 0;
}
