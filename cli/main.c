/* cli/main.c - the `supermat` command-line tool (built as build/supermat)
 *
 *     supermat convert --kind supermat --unet supermat.pth --base stable-diffusion-2-1 --out supermat.safetensors
 *     supermat image --model supermat.safetensors --out maps/ photo.png
 *     supermat image --out maps/ photo.png                       (the default model, see >>model)
 *     supermat views --model supermat_mv.safetensors --cameras meta.json --out maps/ color_000*.png
 *     supermat refine --model uv_refine_bc.safetensors --map uv_bc.png --mask uv_mask.png --position uv_position.png --out maps/
 *     supermat info supermat.safetensors
 *     supermat bench --model supermat.safetensors --size 512
 *     supermat bench --model supermat.safetensors --image photo.png --modes all --json table.json
 *     supermat sheet --out sheet.png --labels input,albedo photo.png,maps/photo_albedo.png
 *
 * One translation unit made of one file per command over one shared I/O module (the .c files of cli, included
 * below in order): it defines SUPERMAT_IMPLEMENTATION and uses the header's public API only (what `bench`
 * times is a documented testing hook), and links with convert/sm_convert.c (and cli/mesh.cpp with tinygltf). Images are read and written
 * with stb_image / stb_image_write (Debian: libstb-dev).
 *
 * Build:  gcc -std=c99 -O2 -I. -Iconvert cli/main.c convert/sm_convert.c -o supermat -lm -lpthread
 *         Windows (MinGW-w64): x86_64-w64-mingw32-gcc -std=c99 -O2 -static -I. -Iconvert cli/main.c convert/sm_convert.c
 *                              -o supermat.exe -lm -lshell32 -lpsapi -lpthread   (tests/test_mingw_cli.sh)
 *         (CMake adds libwebp, zlib and cli/mesh.cpp with tinygltf when it finds them)
 *
 * Files (cli/; each opens with what it holds, sections inside are marked with >>name):
 *   platform.c   >>platform    includes, stb, timing, small helpers, what differs by OS (win32.h: Windows)
 *   args.c       >>args        the tool's own --help, the value parsers (--weights, --kernel, sizes ...);
 *                              opt_table.h: the option tables each command parses and prints its help from
 *   io.c         >>files       the shared I/O module every command writes through: reading a whole file,
 *                              creating folders, the overwrite policy (--force / --skip-existing), atomic
 *                              outputs (FILE.tmp, every write checked, linked / renamed into place), PNG,
 *                              PFM and JSON-report writers
 *                >>inputs      pictures as users have them: 16-bit PNG, EXIF orientation, WebP, folders
 *   model.c      >>model       the default model: where a command without --model finds it ($SUPERMAT_MODEL,
 *                              the installed data folder, the source tree's models/)
 *   convert.c    >>convert     `supermat convert`
 *   download.c   >>download    `supermat download official`: the official weights (curl), then convert
 *   image.c      >>image       `supermat image` (and what `views` and `refine` share with it)
 *   views.c      >>views       `supermat views`: meta.json cameras, the multi-view run
 *   refine.c     >>refine      `supermat refine`
 *   info.c       >>info        `supermat info`
 *   bench.c      >>bench       `supermat bench`: FMA peak, the pipeline per stage, AVX2 vs scalar GEMM
 *                >>benchimage  `supermat bench --image`: the speed / memory levers on a real input against
 *                              the f32 maps and, with --truth-*, against ground truth
 *   sheet.c      >>sheet       `supermat sheet`: a contact sheet of pictures and maps
 *   batch.c      >>batch       `supermat batch`: an asset library, resumable (journal), sharded, --jobs
 *   mesh.cpp                   `supermat mesh` (C++, tinygltf; its own translation unit)
 *   main.c       >>main        this file: the dispatcher
 * A new command is a new file here, included below, writing its outputs through io.c.
 *
 * Exit status: 0 ok, 1 runtime error, 2 usage error.
 */


#include "platform.c"
#include "args.c"
#include "io.c"
#include "model.c"
#include "pack.c"
#include "convert.c"
#include "sha256.c"
#include "download.c"
#include "image.c"
#include "views.c"
#include "refine.c"
#include "info.c"
#include "bench.c"
#include "sheet.c"
#include "batch.c"

/* >>main */
#ifdef SUPERMAT_CLI_MESH
/* cli/mesh.cpp (tinygltf), when built with it: `supermat mesh`, the global options passed in (policy:
   CLI_POLICY_*, allow_outside) */
int supermat_cli_mesh_global(int argc, char **argv, int policy, int allow_outside);
#endif

/* `supermat --help`: the text of args.c, the global options, the exit status */
static const cli_optdef cli_help_main[] = {
    CLI_TEXT(cli_usage_main),
    CLI_OPTS(cli_opts_global),
    CLI_TEXT("\nexit status: 0 ok, 1 runtime error, 2 usage error\n"),
    CLI_END};

int main(int argc, char **argv) {
    const char *c;
    cli_global_opts g;
    cli_platform_args(&argc, &argv); /* UTF-8 on every platform */
    /* the global options, for every command (before a "--", anywhere after the command name): fixed here,
       before the command runs */
    if (cli_global_parse(&argc, argv, &g) != CLI_OK) return CLI_USAGE;
    cli_global_set(&g);
    if (argc < 2) { cli_help_print(stderr, cli_help_main); return CLI_USAGE; }
    c = argv[1];
    if (!strcmp(c, "--help") || !strcmp(c, "-h") || !strcmp(c, "help")) { cli_help_print(stdout, cli_help_main); return CLI_OK; }
    if (!strcmp(c, "--version") || !strcmp(c, "-V")) {
        printf("supermat %d.%d.%d\n", (SUPERMAT_VERSION >> 16) & 255, (SUPERMAT_VERSION >> 8) & 255, SUPERMAT_VERSION & 255);
        printf("built with:%s%s\n",
#ifdef SUPERMAT_CLI_WEBP
               " webp",
#else
               "",
#endif
#ifdef SUPERMAT_CLI_MESH
               " mesh"
#else
               ""
#endif
        );
        return CLI_OK;
    }
    if (supermat_build_optimized() == 0 && strcmp(c, "sheet")) /* nobody measures a debug build by accident */
        fprintf(stderr, "supermat: warning: this supermat was built without optimisation (-O0): about 10x slower; "
                        "build it with -DCMAKE_BUILD_TYPE=Release\n");
    if (!strcmp(c, "convert")) return cli_convert(argc, argv);
    if (!strcmp(c, "pack")) return cli_pack(argc, argv);
    if (!strcmp(c, "download")) return cli_download(argc, argv);
    if (!strcmp(c, "image")) return cli_image(argc, argv);
    if (!strcmp(c, "views")) return cli_views(argc, argv);
    if (!strcmp(c, "refine")) return cli_refine(argc, argv);
    if (!strcmp(c, "info")) return cli_info(argc, argv);
    if (!strcmp(c, "bench")) return cli_bench(argc, argv);
    if (!strcmp(c, "sheet")) return cli_sheet(argc, argv);
    if (!strcmp(c, "batch")) return cli_batch(argc, argv);
    if (!strcmp(c, "mesh")) {
#ifdef SUPERMAT_CLI_MESH
        return supermat_cli_mesh_global(argc - 1, argv + 1, g.policy, g.allow_outside);
#else
        cli_error("this supermat was built without tinygltf (libtinygltf-dev): `mesh` is not available");
        return CLI_FAIL;
#endif
    }
    return cli_usage_error(NULL, "unknown command '%s'", c);
}
