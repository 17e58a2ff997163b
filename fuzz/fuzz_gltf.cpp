/* libFuzzer harness: the CLI's glTF path (`supermat mesh`, cli/mesh.cpp) on a hostile .gltf or .glb:
   tinygltf's parse, the scene walk, node transforms, accessors / buffer views / sparse data read into the
   mesh arrays, materials, texture transforms, images decoded, the bake (passthrough, 8x8 texels, 8x8
   views) and the output asset written (to a folder in /dev/shm; .glb or .gltf by the input's last bit) and
   read back. Input starting with "glTF" is written as in.glb, anything else as in.gltf; the files around it
   (below) make every reference the fuzzer writes a path attack too.

     clang++ -g -O1 -fsanitize=fuzzer,address,undefined -I.. fuzz_gltf.cpp -o fuzz_gltf -ltinygltf -lstb -lpthread
     ./fuzz_gltf -max_total_time=3600 work corpus/gltf */
#define SUPERMAT_MESH_MAIN /* the implementation of supermat.h in this translation unit; main renamed below */
#define main supermat_mesh_main
#include "../cli/mesh.cpp"
#undef main

#include <string>
#include <sys/stat.h>
#include <unistd.h>

/* The folder around the fuzzed asset holds what a hostile reference aims at, so that URIs and links are part
   of what the fuzzer mutates (seeds: corpus/gltf/hostile_*.gltf): the asset's folder asset/ holds a real
   texture (tex.png, sub/t.png), a link to a file outside (out_link.png -> ../secret.png), a linked folder
   (lsub -> ..) and a FIFO (fifo.png); beside it, secret.png holds a marker. After every run, no byte of the
   marker may be in the output (abort: a finding), and a FIFO must not stall the run (-timeout). */
/* the marker: random for each process (the fuzzer cannot learn it from a fixed string), and looked for
   by a plain loop kept out of libFuzzer's comparison tracing (no memcmp / memmem hook feeds it back) */
static std::string g_marker;
#if defined(__clang__)
__attribute__((no_sanitize("coverage")))
#endif
static bool holds(const unsigned char *p, size_t n, const std::string &m) {
    for (size_t i = 0; i + m.size() <= n; i++) {
        size_t k = 0;
        while (k < m.size() && p[i + k] == (unsigned char)m[k]) k++;
        if (k == m.size()) return true;
    }
    return false;
}
static bool holds_marker(const std::string &path) {
    std::vector<unsigned char> b = read_whole(path, true);
    return holds(b.data(), b.size(), g_marker);
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static std::string dir, asset;
    if (dir.empty()) {
        struct stat st;
        dir = std::string(stat("/dev/shm", &st) == 0 ? "/dev/shm" : "/tmp") + "/supermat_fuzz_gltf_" + std::to_string((long)getpid());
        asset = dir + "/asset";
        mkdir(dir.c_str(), 0777);
        mkdir(asset.c_str(), 0777);
        mkdir((asset + "/sub").c_str(), 0777);
        std::freopen("/dev/null", "w", stdout); /* the mesh command's progress lines */
        unsigned char rnd[16] = {0};
        int rfd = open("/dev/urandom", O_RDONLY);
        if (rfd >= 0) { if (read(rfd, rnd, sizeof rnd) != (ssize_t)sizeof rnd) rnd[0] ^= 1; close(rfd); }
        char hex[40];
        for (int i = 0; i < 16; i++) std::snprintf(hex + 2 * i, 3, "%02x", rnd[i]);
        g_marker = std::string("SECRET-") + hex + std::to_string((long)getpid());
        std::string secret = g_marker + " outside the asset\n";
        write_file(dir + "/secret.png", secret.data(), secret.size());
        static const unsigned char px[4] = {200, 120, 40, 255};
        std::vector<unsigned char> png;
        stbi_write_png_to_func(png_to_vec, &png, 1, 1, 4, px, 4);
        write_file(asset + "/tex.png", png.data(), png.size());
        write_file(asset + "/sub/t.png", png.data(), png.size());
        if (symlink("../secret.png", (asset + "/out_link.png").c_str()) != 0 || symlink("..", (asset + "/lsub").c_str()) != 0 ||
            mkfifo((asset + "/fifo.png").c_str(), 0666) != 0)
            std::fprintf(stderr, "fuzz_gltf: could not make the hostile folder (%s)\n", std::strerror(errno));
    }
    bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    /* the last byte picks the output: .glb (everything in one file) or .gltf (referenced files copied beside it) */
    bool gltf_out = size > 0 && (data[size - 1] & 1);
    std::string in = asset + (glb ? "/in.glb" : "/in.gltf"), odir = dir + "/out", out = odir + (gltf_out ? "/out.gltf" : "/out.glb");
    mkdir(odir.c_str(), 0777);
    FILE *f = std::fopen(in.c_str(), "wb");
    if (!f) return 0;
    if (size && std::fwrite(data, 1, size, f) != size) { std::fclose(f); return 0; }
    std::fclose(f);
    const char *argv[] = {"mesh", "--passthrough", "--size", "8", "--views-size", "8", "--supersample", "1", "--threads", "1", "--force",
                          in.c_str(), out.c_str(), nullptr};
    supermat_cli_mesh(13, (char **)argv);
    std::remove(in.c_str());
    std::vector<std::string> files;
    list_files(odir, "", files);
    for (const std::string &o : files)
        if (!holds(data, size, g_marker))
        if (holds_marker(odir + "/" + o)) {
            std::fprintf(stderr, "fuzz_gltf: a byte of a file outside the asset reached the output (%s)\n", o.c_str());
            std::abort();
        }
    char msg[256];
    int ofd = smio_dir_open(dir.c_str(), "", 0, msg, sizeof msg);
    if (ofd >= 0) { smio_rmtree_at(ofd, "out", 0); close(ofd); }
    return 0;
}
