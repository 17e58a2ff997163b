/* libFuzzer harness: the CLI's glTF path (`supermat mesh`, tools/cli/mesh.cpp) on a hostile .gltf or .glb:
   tinygltf's parse, the scene walk, node transforms, accessors / buffer views / sparse data read into the
   mesh arrays, materials, texture transforms, images decoded, the bake (passthrough, 8x8 texels, 8x8
   views) and the output asset written (to a folder in /dev/shm) and read back. Input starting with
   "glTF" is written as in.glb, anything else as in.gltf (JSON, with data-URI buffers and images).

     clang++ -g -O1 -fsanitize=fuzzer,address,undefined -I.. fuzz_gltf.cpp -o fuzz_gltf -ltinygltf -lstb -lpthread
     ./fuzz_gltf -max_total_time=3600 work corpus/gltf */
#define SUPERMAT_MESH_MAIN /* the implementation of supermat.h in this translation unit; main renamed below */
#define main supermat_mesh_main
#include "../tools/cli/mesh.cpp"
#undef main

#include <string>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static std::string dir;
    if (dir.empty()) {
        struct stat st;
        dir = std::string(stat("/dev/shm", &st) == 0 ? "/dev/shm" : "/tmp") + "/supermat_fuzz_gltf_" + std::to_string((long)getpid());
        mkdir(dir.c_str(), 0777);
        std::freopen("/dev/null", "w", stdout); /* the mesh command's progress lines */
    }
    bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    std::string in = dir + (glb ? "/in.glb" : "/in.gltf"), out = dir + "/out.glb";
    FILE *f = std::fopen(in.c_str(), "wb");
    if (!f) return 0;
    if (size && std::fwrite(data, 1, size, f) != size) { std::fclose(f); return 0; }
    std::fclose(f);
    const char *argv[] = {"mesh", "--passthrough", "--size", "8", "--views-size", "8", "--supersample", "1", "--threads", "1", "--force",
                          in.c_str(), out.c_str(), nullptr};
    supermat_cli_mesh(13, (char **)argv);
    std::remove(in.c_str());
    return 0;
}
