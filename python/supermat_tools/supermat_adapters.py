"""SuperMat's network classes, written for this project from the behaviour of the official code
(github hyj542682306/SuperMat, src/adapters.py and src/models/), so that training needs nothing beside the
repository: only an ordinary `diffusers` and `torch` on the Python path.

What is here, each with the official name, the same module tree and therefore the same state_dict keys (the
checkpoints the training scripts write are in the official release format):

  SuperMatUNet2DConditionModel   a diffusers UNet2DConditionModel whose last up block and conv_out are
                                 replicated into `replicate_num` expert branches: `last_up_blocks.<i>`,
                                 `rep_conv_out.<i>` (the plain `up_blocks.<last>` and `conv_out` are removed);
                                 forward returns a list, one output per branch.
  UVRefineUNet2DConditionModel   the UV-refine network: conv_in and the first down block replicated too
                                 (`rep_conv_in.<i>`, `first_down_blocks.<i>`); forward takes a list of inputs,
                                 one per branch, averages the branches after the first down block, and feeds
                                 each branch's own skips to the second-to-last up block (run once per branch)
                                 and to its last up block.
  SuperMatAdapterWrapper.convert / UVRefineAdapterWrapper.convert
                                 a pipeline-like object's plain `unet` -> the SuperMat / UV-refine UNet
                                 (optionally with the camera embedding: class_embed_type "projection"),
                                 weights carried over, then replicated.
  MVAttnProcessor2_0, set_supermat_mv_self_attention
                                 the multi-view self-attention of SuperMatMV: every view's query attends to the
                                 keys / values of all `num_views` views of its object (batch rows are grouped
                                 object-major, views consecutive).

Like the official classes, attention processors set through `set_attn_processor` skip every module whose
name contains "down_blocks.0" or "up_blocks.3", so the first down block keeps per-view attention.
Only the inference / training paths the project uses are supported: no ControlNet / T2I-adapter residuals,
no GLIGEN, no xformers (the multi-view attention is the scaled-dot-product one).

Also here, for torch 1.13 (Debian 12's python3-torch), which lacks F.scaled_dot_product_attention: the exact
math of it, installed into torch.nn.functional when missing, BEFORE diffusers is imported (diffusers then
picks AttnProcessor2_0 as on torch 2.x).  Score matrices over SDPA_CHUNK_ELEMS elements (environment
SUPERMAT_SDPA_CHUNK_ELEMS, default 2**26) are computed in pieces along the queries.  And synthetic_clip_vocab,
the tokenizer vocabulary the releases ship (no pretrained CLIP exists here).

Versions: diffusers 0.27 or newer (the UNet's get_time_embed / get_class_embed / get_aug_embed helpers);
checked with diffusers 0.31.0 on torch 1.13.1 (Debian) with huggingface_hub 0.35.3.  Import this module
before diffusers.
"""
import copy
import os
from typing import Any, Dict, List, Optional

import torch
import torch.nn as nn
import torch.nn.functional as F

# ----------------------------------------------------------------------------------------------------------
# torch 1.13: scaled dot-product attention
# ----------------------------------------------------------------------------------------------------------
SDPA_CHUNK_ELEMS = int(os.environ.get("SUPERMAT_SDPA_CHUNK_ELEMS", str(1 << 26)))
SDPA_SHIM_INSTALLED = False


def _attend(q, k, v, mask, causal, scale, row0):
    s = torch.matmul(q, k.transpose(-2, -1)) * scale
    if causal:
        keep = torch.ones(q.shape[-2], k.shape[-2], dtype=torch.bool, device=q.device).tril(row0)
        s = s.masked_fill(~keep, float("-inf"))
    if mask is not None:
        s = s.masked_fill(~mask, float("-inf")) if mask.dtype == torch.bool else s + mask
    return torch.matmul(torch.softmax(s, dim=-1), v)


def sdpa_math(query, key, value, attn_mask=None, dropout_p=0.0, is_causal=False, scale=None, **unused):
    """softmax(Q K^T * scale + mask) V, scale 1/sqrt(head dim) by default (torch 2's definition, no dropout);
    the query rows are taken in pieces when the scores would pass SDPA_CHUNK_ELEMS elements."""
    if dropout_p:
        raise NotImplementedError("supermat_adapters.sdpa_math: dropout")
    if scale is None:
        scale = query.shape[-1] ** -0.5
    n_q, n_k = query.shape[-2], key.shape[-2]
    lead = 1
    for d in query.shape[:-2]:
        lead *= d
    rows = max(1, SDPA_CHUNK_ELEMS // max(1, lead * n_k))
    if rows >= n_q:
        return _attend(query, key, value, attn_mask, is_causal, scale, 0)
    parts = []
    for r0 in range(0, n_q, rows):
        m = attn_mask
        if m is not None and m.shape[-2] == n_q:
            m = m[..., r0:r0 + rows, :]
        parts.append(_attend(query[..., r0:r0 + rows, :], key, value, m, is_causal, scale, r0))
    return torch.cat(parts, dim=-2)


if not hasattr(F, "scaled_dot_product_attention"):
    F.scaled_dot_product_attention = sdpa_math
    SDPA_SHIM_INSTALLED = True

try:
    from diffusers import UNet2DConditionModel  # noqa: E402
    from diffusers.models.unets.unet_2d_condition import UNet2DConditionOutput  # noqa: E402
except ImportError as e:
    raise ImportError(f"supermat_adapters: {e}: diffusers 0.27 or newer (checked with 0.31.0) must be importable: "
                      "`pip install diffusers==0.31.0`, or PYTHONPATH naming extracted sources (the training scripts put $HARNESS_DEPS/site there)") from e


# ----------------------------------------------------------------------------------------------------------
# tokenizer vocabulary
# ----------------------------------------------------------------------------------------------------------
def _byte_chars():
    """GPT-2 / CLIP byte -> printable character table, in byte order."""
    keep = list(range(ord("!"), ord("~") + 1)) + list(range(0xA1, 0xAD)) + list(range(0xAE, 0x100))
    extra = 0
    out = {}
    for b in range(256):
        if b in keep:
            out[b] = chr(b)
        else:
            out[b] = chr(256 + extra)
            extra += 1
    return [out[b] for b in sorted(keep)] + [out[b] for b in range(256) if b not in keep]


def synthetic_clip_vocab(vocab_size=49408):
    """CLIP's vocabulary layout where it matters: ids 0..255 the byte characters (so "!" is 0, SD 2.1's pad
    token), 256..511 the same with "</w>", the last two ids start / end of text; the ids between (BPE merges
    in the real vocabulary) are unused placeholders."""
    chars = _byte_chars()
    vocab = {c: i for i, c in enumerate(chars)}
    vocab.update({c + "</w>": 256 + i for i, c in enumerate(chars)})
    for i in range(512, vocab_size - 2):
        vocab[f"<|harness_unused_{i}|>"] = i   # the name the shipped tokenizers carry
    vocab["<|startoftext|>"] = vocab_size - 2
    vocab["<|endoftext|>"] = vocab_size - 1
    return vocab


# ----------------------------------------------------------------------------------------------------------
# the UNets
# ----------------------------------------------------------------------------------------------------------
_SKIP_PROCESSOR = ("down_blocks.0", "up_blocks.3")


def _set_processors(model, processor):
    def walk(name, module):
        if any(s in name for s in _SKIP_PROCESSOR):
            return
        if hasattr(module, "set_processor"):
            module.set_processor(processor.pop(f"{name}.processor") if isinstance(processor, dict) else processor)
        for sub, child in module.named_children():
            walk(f"{name}.{sub}", child)

    for name, module in model.named_children():
        walk(name, module)


def _run_block(block, h, emb, ehs, skips, upsample_size, attention_mask, encoder_attention_mask, xattn_kwargs):
    if getattr(block, "has_cross_attention", False):
        return block(hidden_states=h, temb=emb, res_hidden_states_tuple=skips, encoder_hidden_states=ehs,
                     cross_attention_kwargs=xattn_kwargs, upsample_size=upsample_size,
                     attention_mask=attention_mask, encoder_attention_mask=encoder_attention_mask)
    return block(hidden_states=h, temb=emb, res_hidden_states_tuple=skips, upsample_size=upsample_size)


def _run_down(block, h, emb, ehs, attention_mask, encoder_attention_mask, xattn_kwargs):
    if getattr(block, "has_cross_attention", False):
        return block(hidden_states=h, temb=emb, encoder_hidden_states=ehs, attention_mask=attention_mask,
                     cross_attention_kwargs=xattn_kwargs, encoder_attention_mask=encoder_attention_mask)
    return block(hidden_states=h, temb=emb)


def _run_mid(mid, h, emb, ehs, attention_mask, encoder_attention_mask, xattn_kwargs):
    if mid is None:
        return h
    if getattr(mid, "has_cross_attention", False):
        return mid(h, emb, encoder_hidden_states=ehs, attention_mask=attention_mask,
                   cross_attention_kwargs=xattn_kwargs, encoder_attention_mask=encoder_attention_mask)
    return mid(h, emb)


def _replicas(module, n):
    return nn.ModuleList([copy.deepcopy(module) for _ in range(n)])


class _BranchedUNet(UNet2DConditionModel):
    """What both SuperMat UNets share: processors, the embeddings, masks as biases."""

    def set_attn_processor(self, processor):
        _set_processors(self, processor)

    @staticmethod
    def _unsupported(kw):
        bad = [k for k in ("down_block_additional_residuals", "mid_block_additional_residual",
                           "down_intrablock_additional_residuals") if kw.get(k) is not None]
        if bad:
            raise NotImplementedError(f"supermat_adapters: {', '.join(bad)} not supported")

    def _prepare(self, like, timestep, encoder_hidden_states, class_labels, timestep_cond, attention_mask,
                 encoder_attention_mask, added_cond_kwargs, cross_attention_kwargs):
        """(emb, encoder_hidden_states, attention_mask, encoder_attention_mask, cross_attention_kwargs) as
        diffusers' UNet2DConditionModel.forward makes them (`like`: a sample tensor for dtype / device)."""
        if attention_mask is not None:
            attention_mask = ((1 - attention_mask.to(like.dtype)) * -10000.0).unsqueeze(1)
        if encoder_attention_mask is not None:
            encoder_attention_mask = ((1 - encoder_attention_mask.to(like.dtype)) * -10000.0).unsqueeze(1)
        emb = self.time_embedding(self.get_time_embed(sample=like, timestep=timestep), timestep_cond)
        class_emb = self.get_class_embed(sample=like, class_labels=class_labels)
        if class_emb is not None:
            emb = torch.cat([emb, class_emb], dim=-1) if self.config.class_embeddings_concat else emb + class_emb
        aug = self.get_aug_embed(emb=emb, encoder_hidden_states=encoder_hidden_states,
                                 added_cond_kwargs=added_cond_kwargs)
        if self.config.addition_embed_type == "image_hint":
            raise NotImplementedError("supermat_adapters: addition_embed_type image_hint")
        if aug is not None:
            emb = emb + aug
        if self.time_embed_act is not None:
            emb = self.time_embed_act(emb)
        encoder_hidden_states = self.process_encoder_hidden_states(encoder_hidden_states=encoder_hidden_states,
                                                                   added_cond_kwargs=added_cond_kwargs)
        if cross_attention_kwargs is not None:
            cross_attention_kwargs = dict(cross_attention_kwargs)
            cross_attention_kwargs.pop("scale", None)
            if cross_attention_kwargs.get("gligen") is not None:
                raise NotImplementedError("supermat_adapters: GLIGEN")
        return emb, encoder_hidden_states, attention_mask, encoder_attention_mask, cross_attention_kwargs

    def _head(self, h):
        if self.conv_norm_out:
            h = self.conv_act(self.conv_norm_out(h))
        return h


class SuperMatUNet2DConditionModel(_BranchedUNet):
    def replicate(self, replicate_num: int = 2, shared_blocks_lora: bool = True):
        """Move the last up block and conv_out into `replicate_num` identical copies (the expert branches)."""
        self.replicate_num = replicate_num
        self.last_up_blocks = _replicas(self.up_blocks[-1], replicate_num)
        del self.up_blocks[-1]
        self.rep_conv_out = _replicas(self.conv_out, replicate_num)
        del self.conv_out
        if shared_blocks_lora:
            self.last_up_blocks.requires_grad_(True)
            self.rep_conv_out.requires_grad_(True)

    def forward(self, sample, timestep, encoder_hidden_states, class_labels=None, timestep_cond=None,
                attention_mask=None, cross_attention_kwargs: Optional[Dict[str, Any]] = None,
                added_cond_kwargs=None, encoder_attention_mask=None, return_dict: bool = True, **kw):
        """sample [B, C, H, W] -> one output per branch (a list), as UNet2DConditionOutput.sample or (list,)."""
        self._unsupported(kw)
        up_factor = 2 ** self.num_upsamplers
        pass_size = any(d % up_factor for d in sample.shape[-2:])
        upsample_size = None
        emb, ehs, am, eam, xk = self._prepare(sample, timestep, encoder_hidden_states, class_labels, timestep_cond,
                                              attention_mask, encoder_attention_mask, added_cond_kwargs,
                                              cross_attention_kwargs)
        if self.config.center_input_sample:
            sample = 2 * sample - 1.0
        h = self.conv_in(sample)
        skips = (h,)
        for block in self.down_blocks:
            h, res = _run_down(block, h, emb, ehs, am, eam, xk)
            skips += res
        h = _run_mid(self.mid_block, h, emb, ehs, am, eam, xk)
        for block in self.up_blocks:
            n = len(block.resnets)
            res, skips = skips[-n:], skips[:-n]
            if pass_size:
                upsample_size = skips[-1].shape[2:]
            h = _run_block(block, h, emb, ehs, res, upsample_size, am, eam, xk)
        outs = []
        for block, conv in zip(self.last_up_blocks, self.rep_conv_out):
            res = skips[-len(block.resnets):]
            outs.append(conv(self._head(_run_block(block, h, emb, ehs, res, upsample_size, am, eam, xk))))
        if not return_dict:
            return (outs,)
        return UNet2DConditionOutput(sample=outs)


class UVRefineUNet2DConditionModel(_BranchedUNet):
    def replicate(self, replicate_num: int = 4, shared_blocks_lora: bool = True):
        """Move conv_in, the first down block, the last up block and conv_out into `replicate_num` copies."""
        self.replicate_num = replicate_num
        self.rep_conv_in = _replicas(self.conv_in, replicate_num)
        del self.conv_in
        self.first_down_blocks = _replicas(self.down_blocks[0], replicate_num)
        del self.down_blocks[0]
        self.last_up_blocks = _replicas(self.up_blocks[-1], replicate_num)
        del self.up_blocks[-1]
        self.rep_conv_out = _replicas(self.conv_out, replicate_num)
        del self.conv_out
        if shared_blocks_lora:
            for m in (self.rep_conv_in, self.first_down_blocks, self.last_up_blocks, self.rep_conv_out):
                m.requires_grad_(True)

    def forward(self, sample: List[torch.Tensor], timestep, encoder_hidden_states, class_labels=None,
                timestep_cond=None, attention_mask=None, cross_attention_kwargs: Optional[Dict[str, Any]] = None,
                added_cond_kwargs=None, encoder_attention_mask=None, return_dict: bool = True, **kw):
        """sample: one [B, C, H, W] input per branch -> one output per branch (a list)."""
        self._unsupported(kw)
        if self.config.center_input_sample:
            raise NotImplementedError("supermat_adapters: center_input_sample with a list of inputs")
        up_factor = 2 ** self.num_upsamplers
        pass_size = any(d % up_factor for d in sample[0].shape[-2:])
        upsample_size = None
        emb, ehs, am, eam, xk = self._prepare(sample[0], timestep, encoder_hidden_states, class_labels,
                                              timestep_cond, attention_mask, encoder_attention_mask,
                                              added_cond_kwargs, cross_attention_kwargs)
        first_in = [conv(x) for conv, x in zip(self.rep_conv_in, sample)]
        branch_skips, firsts = [], []
        for block, x in zip(self.first_down_blocks, first_in):
            h_i, res = _run_down(block, x, emb, ehs, am, eam, xk)
            firsts.append(h_i)
            branch_skips.append((x,) + res)
        h = torch.stack(firsts, dim=0).mean(dim=0)
        skips = ()
        for block in self.down_blocks:
            h, res = _run_down(block, h, emb, ehs, am, eam, xk)
            skips += res
        h = _run_mid(self.mid_block, h, emb, ehs, am, eam, xk)
        per_branch = []
        last = len(self.up_blocks) - 1
        for i, block in enumerate(self.up_blocks):
            if i < last:
                n = len(block.resnets)
                res, skips = skips[-n:], skips[:-n]
                if pass_size:
                    upsample_size = skips[-1].shape[2:]
                h = _run_block(block, h, emb, ehs, res, upsample_size, am, eam, xk)
                continue
            # the block before the replicated one: once per branch, its deepest skip from that branch
            for j in range(self.replicate_num):
                res = branch_skips[j][-1:] + skips
                branch_skips[j] = branch_skips[j][:-1]
                if pass_size:
                    upsample_size = branch_skips[j][-1].shape[2:]
                per_branch.append(_run_block(block, h, emb, ehs, res, upsample_size, am, eam, xk))
        outs = []
        for j in range(self.replicate_num):
            y = _run_block(self.last_up_blocks[j], per_branch[j], emb, ehs, branch_skips[j], upsample_size,
                           am, eam, xk)
            outs.append(self.rep_conv_out[j](self._head(y)))
        if not return_dict:
            return (outs,)
        return UNet2DConditionOutput(sample=outs)


def _camera_kwargs(use_camera_embeddings, camera_embeddings_dim):
    if not use_camera_embeddings:
        return {}
    return {"class_embed_type": "projection", "projection_class_embeddings_input_dim": camera_embeddings_dim}


class SuperMatAdapterWrapper:
    @staticmethod
    def convert(pipeline, use_camera_embeddings: bool, camera_embeddings_dim: Optional[int] = None,
                replicate_num: int = 2):
        """pipeline.unet (a plain UNet2DConditionModel) -> SuperMatUNet2DConditionModel with its weights
        (the camera embedding, when asked for, is new), replicated into `replicate_num` branches."""
        unet = SuperMatUNet2DConditionModel.from_config(
            pipeline.unet.config, **_camera_kwargs(use_camera_embeddings, camera_embeddings_dim))
        unet.load_state_dict(pipeline.unet.state_dict(), strict=False)
        unet.replicate(replicate_num=replicate_num, shared_blocks_lora=False)
        pipeline.unet = unet
        return pipeline


class UVRefineAdapterWrapper:
    @staticmethod
    def convert(pipeline, use_camera_embeddings: bool, camera_embeddings_dim: Optional[int] = None,
                replicate_num: int = 2):
        """pipeline.unet -> UVRefineUNet2DConditionModel with 8 input channels (latent 4 + mask + position):
        its weights, conv_in's first 4 input channels from the plain UNet, then replicated."""
        unet = UVRefineUNet2DConditionModel.from_config(
            pipeline.unet.config, in_channels=8, **_camera_kwargs(use_camera_embeddings, camera_embeddings_dim))
        unet.load_state_dict({k: v for k, v in pipeline.unet.state_dict().items() if k != "conv_in.weight"},
                             strict=False)
        with torch.no_grad():
            unet.conv_in.weight[:, :4] = pipeline.unet.conv_in.weight
        unet.replicate(replicate_num=replicate_num, shared_blocks_lora=False)
        pipeline.unet = unet
        return pipeline


# ----------------------------------------------------------------------------------------------------------
# multi-view self-attention
# ----------------------------------------------------------------------------------------------------------
class MVAttnProcessor2_0:
    """Self-attention over the views of one object: rows of the batch are objects x num_views (views
    consecutive); each view's queries attend to the keys / values of all its object's views."""

    def __init__(self, num_views: int = 1):
        self.num_views = num_views

    def set_num_views(self, num_views: int) -> None:
        self.num_views = num_views

    def _group(self, t, heads, head_dim):
        # [B*V, N, heads*hd] -> [B*V, heads, V*N, hd]: all views' tokens of the object, repeated per view
        bv, n, _ = t.shape
        v = self.num_views
        t = t.view(bv // v, v, n, heads, head_dim).permute(0, 3, 1, 2, 4).reshape(bv // v, heads, v * n, head_dim)
        return t.repeat_interleave(v, dim=0)

    def __call__(self, attn, hidden_states, encoder_hidden_states=None, attention_mask=None, temb=None,
                 *args, **kwargs):
        residual = hidden_states
        if attn.spatial_norm is not None:
            hidden_states = attn.spatial_norm(hidden_states, temb)
        ndim = hidden_states.ndim
        if ndim == 4:
            b, c, hh, ww = hidden_states.shape
            hidden_states = hidden_states.view(b, c, hh * ww).transpose(1, 2)
        src = hidden_states if encoder_hidden_states is None else encoder_hidden_states
        batch, seq = src.shape[0], src.shape[1]
        if attention_mask is not None:
            attention_mask = attn.prepare_attention_mask(attention_mask, seq, batch)
            attention_mask = attention_mask.view(batch, attn.heads, -1, attention_mask.shape[-1])
        if attn.group_norm is not None:
            hidden_states = attn.group_norm(hidden_states.transpose(1, 2)).transpose(1, 2)
        query = attn.to_q(hidden_states)
        if encoder_hidden_states is None:
            encoder_hidden_states = hidden_states
        elif attn.norm_cross:
            encoder_hidden_states = attn.norm_encoder_hidden_states(encoder_hidden_states)
        key = attn.to_k(encoder_hidden_states)
        value = attn.to_v(encoder_hidden_states)
        head_dim = key.shape[-1] // attn.heads
        query = query.view(batch, -1, attn.heads, head_dim).transpose(1, 2)
        key = self._group(key, attn.heads, head_dim)
        value = self._group(value, attn.heads, head_dim)
        out = F.scaled_dot_product_attention(query, key, value, attn_mask=attention_mask, dropout_p=0.0,
                                             is_causal=False)
        out = out.transpose(1, 2).reshape(batch, -1, attn.heads * head_dim).to(query.dtype)
        out = attn.to_out[1](attn.to_out[0](out))
        if ndim == 4:
            out = out.transpose(-1, -2).reshape(b, c, hh, ww)
        if attn.residual_connection:
            out = out + residual
        return out / attn.rescale_output_factor


def set_supermat_mv_self_attention(model, num_views: int, attn_positions: Optional[List[str]] = None,
                                   use_xformers: bool = False):
    """Give every self-attention (attn1) of `model` whose name contains one of `attn_positions` (all when None)
    a multi-view processor over `num_views` views; the rest keep theirs (and the model's set_attn_processor
    leaves down_blocks.0 / up_blocks.3 alone)."""
    if use_xformers:
        raise NotImplementedError("supermat_adapters: only the scaled-dot-product multi-view attention is ported")
    procs = {}
    for name, proc in model.attn_processors.items():
        self_attn = name.endswith("attn1.processor") or "motion_modules" in name
        if self_attn and (attn_positions is None or any(p in name for p in attn_positions)):
            procs[name] = MVAttnProcessor2_0(num_views=num_views)
        else:
            procs[name] = proc
    model.set_attn_processor(procs)
