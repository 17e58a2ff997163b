/* cli/sheet.c - `supermat sheet`: a contact sheet of pictures and maps.
 * Part of the `supermat` CLI: included by cli/main.c (one translation unit), not compiled alone. */

/* >>sheet */
/* `supermat sheet`: its options and --help */
enum { CLI_SHEET_OUT = 1, CLI_SHEET_CELL, CLI_SHEET_LABELS };
static const cli_optdef cli_opts_sheet[] = {
    CLI_TEXT("usage: supermat sheet --out SHEET.png [--cell N] [--labels LIST] ROW...\n"
             "\n"
             "Puts pictures side by side in one PNG, a contact sheet. Each ROW is one row of the sheet: a comma\n"
             "list of image files (read with stb_image: PNG, JPEG, BMP, TGA, ...), one per column; - leaves a\n"
             "cell empty, and a row shorter than the longest leaves its last cells empty. For a picture and its\n"
             "maps:\n"
             "  supermat sheet --out sheet.png --labels input,albedo,roughness,metallic \\\n"
             "      photo.png,out/photo_albedo.png,out/photo_roughness.png,out/photo_metallic.png\n"
             "\n"
             "Each image is resized to fit an N x N cell keeping its shape (square images fill it; a box\n"
             "filter when shrinking, bilinear when enlarging) and centred in it. Transparent pixels show a\n"
             "light checkerboard behind them; gray images are shown as gray. FILE:r, :g, :b or :a shows that one\n"
             "channel of FILE as gray (e.g. a glTF metallicRoughness texture: roughness :g, metallic :b). Cells are separated by 4-pixel\n"
             "gutters on a white background: the sheet is 4 + C * (N + 4) pixels wide and 4 + R * (N + 4)\n"
             "high for C columns and R rows, plus 8 * S + 4 rows for the labels when --labels is given\n"
             "(S = 1 + N / 256, the text scale: 1 up to N = 255). The PNG is RGB, 8-bit, written as\n"
             "a temporary file and renamed when complete; on any error nothing is written.\n"
             "\n"
             "options:\n"),
    {CLI_SHEET_OUT, "--out", "FILE", "the PNG to write (required)", NULL, NULL},
    {CLI_SHEET_CELL, "--cell", "N", "the cell size in pixels, 8 to 1024 (default 128)", NULL, NULL},
    {CLI_SHEET_LABELS, "--labels", "LIST", "comma list of column titles, printed above the columns in a small bitmap\n"
                                           "font (letters, digits, space and . , _ - / ( ) : = + % ' ! ?; any other\n"
                                           "character prints as ?); a title wider than its column is cut", NULL, NULL},
    CLI_END};

/* 5x8 glyphs of the characters in cli_font_chars: 8 rows top to bottom (rows 0-6 above the
   baseline, row 7 below it), bit 4 = the leftmost column */
static const char cli_font_chars[] = " !%'()+,-./0123456789:=?ABCDEFGHIJKLMNOPQRSTUVWXYZ_abcdefghijklmnopqrstuvwxyz";
static const unsigned char cli_font[][8] = {
    {0x00,0x00,0x00,0x00,0x00,0x00,0x00,0x00}, {0x04,0x04,0x04,0x04,0x04,0x00,0x04,0x00}, {0x18,0x19,0x02,0x04,0x08,0x13,0x03,0x00}, {0x04,0x04,0x08,0x00,0x00,0x00,0x00,0x00},
    {0x02,0x04,0x08,0x08,0x08,0x04,0x02,0x00}, {0x08,0x04,0x02,0x02,0x02,0x04,0x08,0x00}, {0x00,0x04,0x04,0x1f,0x04,0x04,0x00,0x00}, {0x00,0x00,0x00,0x00,0x00,0x06,0x04,0x08},
    {0x00,0x00,0x00,0x1f,0x00,0x00,0x00,0x00}, {0x00,0x00,0x00,0x00,0x00,0x0c,0x0c,0x00}, {0x01,0x02,0x02,0x04,0x08,0x08,0x10,0x00}, {0x0e,0x11,0x13,0x15,0x19,0x11,0x0e,0x00},
    {0x04,0x0c,0x04,0x04,0x04,0x04,0x0e,0x00}, {0x0e,0x11,0x01,0x02,0x04,0x08,0x1f,0x00}, {0x1f,0x02,0x04,0x02,0x01,0x11,0x0e,0x00}, {0x02,0x06,0x0a,0x12,0x1f,0x02,0x02,0x00},
    {0x1f,0x10,0x1e,0x01,0x01,0x11,0x0e,0x00}, {0x06,0x08,0x10,0x1e,0x11,0x11,0x0e,0x00}, {0x1f,0x01,0x02,0x04,0x08,0x08,0x08,0x00}, {0x0e,0x11,0x11,0x0e,0x11,0x11,0x0e,0x00},
    {0x0e,0x11,0x11,0x0f,0x01,0x02,0x0c,0x00}, {0x00,0x0c,0x0c,0x00,0x0c,0x0c,0x00,0x00}, {0x00,0x00,0x1f,0x00,0x1f,0x00,0x00,0x00}, {0x0e,0x11,0x01,0x02,0x04,0x00,0x04,0x00},
    {0x0e,0x11,0x11,0x1f,0x11,0x11,0x11,0x00}, {0x1e,0x11,0x11,0x1e,0x11,0x11,0x1e,0x00}, {0x0e,0x11,0x10,0x10,0x10,0x11,0x0e,0x00}, {0x1c,0x12,0x11,0x11,0x11,0x12,0x1c,0x00},
    {0x1f,0x10,0x10,0x1e,0x10,0x10,0x1f,0x00}, {0x1f,0x10,0x10,0x1e,0x10,0x10,0x10,0x00}, {0x0e,0x11,0x10,0x17,0x11,0x11,0x0f,0x00}, {0x11,0x11,0x11,0x1f,0x11,0x11,0x11,0x00},
    {0x0e,0x04,0x04,0x04,0x04,0x04,0x0e,0x00}, {0x07,0x02,0x02,0x02,0x02,0x12,0x0c,0x00}, {0x11,0x12,0x14,0x18,0x14,0x12,0x11,0x00}, {0x10,0x10,0x10,0x10,0x10,0x10,0x1f,0x00},
    {0x11,0x1b,0x15,0x15,0x11,0x11,0x11,0x00}, {0x11,0x11,0x19,0x15,0x13,0x11,0x11,0x00}, {0x0e,0x11,0x11,0x11,0x11,0x11,0x0e,0x00}, {0x1e,0x11,0x11,0x1e,0x10,0x10,0x10,0x00},
    {0x0e,0x11,0x11,0x11,0x15,0x12,0x0d,0x00}, {0x1e,0x11,0x11,0x1e,0x14,0x12,0x11,0x00}, {0x0f,0x10,0x10,0x0e,0x01,0x01,0x1e,0x00}, {0x1f,0x04,0x04,0x04,0x04,0x04,0x04,0x00},
    {0x11,0x11,0x11,0x11,0x11,0x11,0x0e,0x00}, {0x11,0x11,0x11,0x11,0x11,0x0a,0x04,0x00}, {0x11,0x11,0x11,0x15,0x15,0x15,0x0a,0x00}, {0x11,0x11,0x0a,0x04,0x0a,0x11,0x11,0x00},
    {0x11,0x11,0x0a,0x04,0x04,0x04,0x04,0x00}, {0x1f,0x01,0x02,0x04,0x08,0x10,0x1f,0x00}, {0x00,0x00,0x00,0x00,0x00,0x00,0x00,0x1f}, {0x00,0x00,0x0e,0x01,0x0f,0x11,0x0f,0x00},
    {0x10,0x10,0x16,0x19,0x11,0x11,0x1e,0x00}, {0x00,0x00,0x0e,0x10,0x10,0x11,0x0e,0x00}, {0x01,0x01,0x0d,0x13,0x11,0x11,0x0f,0x00}, {0x00,0x00,0x0e,0x11,0x1f,0x10,0x0e,0x00},
    {0x06,0x09,0x08,0x1c,0x08,0x08,0x08,0x00}, {0x00,0x00,0x0f,0x11,0x11,0x0f,0x01,0x0e}, {0x10,0x10,0x16,0x19,0x11,0x11,0x11,0x00}, {0x04,0x00,0x0c,0x04,0x04,0x04,0x0e,0x00},
    {0x02,0x00,0x06,0x02,0x02,0x02,0x12,0x0c}, {0x10,0x10,0x12,0x14,0x18,0x14,0x12,0x00}, {0x0c,0x04,0x04,0x04,0x04,0x04,0x0e,0x00}, {0x00,0x00,0x1a,0x15,0x15,0x11,0x11,0x00},
    {0x00,0x00,0x16,0x19,0x11,0x11,0x11,0x00}, {0x00,0x00,0x0e,0x11,0x11,0x11,0x0e,0x00}, {0x00,0x00,0x1e,0x11,0x11,0x1e,0x10,0x10}, {0x00,0x00,0x0f,0x11,0x11,0x0f,0x01,0x01},
    {0x00,0x00,0x16,0x19,0x10,0x10,0x10,0x00}, {0x00,0x00,0x0f,0x10,0x0e,0x01,0x1e,0x00}, {0x08,0x08,0x1c,0x08,0x08,0x09,0x06,0x00}, {0x00,0x00,0x11,0x11,0x11,0x13,0x0d,0x00},
    {0x00,0x00,0x11,0x11,0x11,0x0a,0x04,0x00}, {0x00,0x00,0x11,0x11,0x15,0x15,0x0a,0x00}, {0x00,0x00,0x11,0x0a,0x04,0x0a,0x11,0x00}, {0x00,0x00,0x11,0x11,0x11,0x0f,0x01,0x0e},
    {0x00,0x00,0x1f,0x02,0x04,0x08,0x1f,0x00},
};
#define CLI_SHEET_GUTTER 4
#define CLI_SHEET_INK 40

static const unsigned char *cli_glyph(char c) {
    const char *p = c ? strchr(cli_font_chars, c) : NULL;
    if (!p) p = strchr(cli_font_chars, '?');
    return cli_font[p - cli_font_chars];
}

/* text of n characters at (x, y) (its top left) in scale s, clipped to the sheet (sw x sh, RGB) */
static void cli_sheet_text(unsigned char *sheet, int sw, int sh, int x, int y, const char *text, int n, int s) {
    int i, r, c, dy, dx;
    for (i = 0; i < n; i++) {
        const unsigned char *g = cli_glyph(text[i]);
        for (r = 0; r < 8; r++)
            for (c = 0; c < 5; c++) {
                if (!(g[r] & (0x10 >> c))) continue;
                for (dy = 0; dy < s; dy++)
                    for (dx = 0; dx < s; dx++) {
                        int px = x + (i * 6 + c) * s + dx, py = y + r * s + dy;
                        unsigned char *p;
                        if (px < 0 || py < 0 || px >= sw || py >= sh) continue;
                        p = sheet + ((size_t)py * sw + px) * 3;
                        p[0] = p[1] = p[2] = CLI_SHEET_INK;
                    }
            }
    }
}

/* The source pixels and weights of each of dst outputs along one axis of src pixels: a box filter
   (each source pixel weighted by how much of it the output pixel covers) when shrinking, bilinear
   (pixel centres aligned, edges clamped) otherwise. idx and w hold dst * *taps entries. */
static int cli_resample_axis(int src, int dst, int **idx, float **w, int *taps) {
    double scale = (double)src / dst;
    int o, k, t = src > dst ? (int)ceil(scale) + 1 : 2;
    *idx = (int *)malloc(sizeof(int) * (size_t)dst * (size_t)t);
    *w = (float *)malloc(sizeof(float) * (size_t)dst * (size_t)t);
    *taps = t;
    if (!*idx || !*w) { free(*idx); free(*w); *idx = NULL; *w = NULL; return CLI_FAIL; }
    for (o = 0; o < dst; o++) {
        int *ii = *idx + (size_t)o * t;
        float *ww = *w + (size_t)o * t;
        if (src > dst) {
            double a = o * scale, b = a + scale;
            int i0 = (int)floor(a);
            for (k = 0; k < t; k++) {
                int i = i0 + k;
                double lo = a > i ? a : i, hi = b < i + 1 ? b : i + 1;
                ii[k] = i < src ? i : src - 1;
                ww[k] = hi > lo && i < src ? (float)((hi - lo) / scale) : 0.0f;
            }
        } else {
            double c = (o + 0.5) * scale - 0.5, f;
            int i0 = (int)floor(c);
            f = c - i0;
            ii[0] = i0 < 0 ? 0 : i0 > src - 1 ? src - 1 : i0;
            ii[1] = i0 + 1 < 0 ? 0 : i0 + 1 > src - 1 ? src - 1 : i0 + 1;
            ww[0] = (float)(1.0 - f);
            ww[1] = (float)f;
        }
    }
    return CLI_OK;
}

/* Draws px (w x h, RGBA 8-bit, straight alpha) resized to dw x dh with its top left at (x0, y0) of
   the sheet (sw pixels wide, RGB), over a checkerboard of q-pixel squares. Resampled with alpha
   premultiplied (no dark fringes), then composited. */
static int cli_sheet_draw(unsigned char *sheet, int sw, int x0, int y0, const unsigned char *px, int w, int h, int dw, int dh, int q) {
    int *ix = NULL, *iy = NULL, tx, ty, x, y, k, c;
    float *wx = NULL, *wy = NULL, *tmp = NULL;
    int rc = CLI_FAIL;
    if (cli_resample_axis(w, dw, &ix, &wx, &tx) != CLI_OK || cli_resample_axis(h, dh, &iy, &wy, &ty) != CLI_OK) goto done;
    tmp = (float *)malloc(sizeof(float) * 4 * (size_t)dw * (size_t)h);
    if (!tmp) goto done;
    for (y = 0; y < h; y++) /* horizontal: premultiplied RGBA in [0, 255] */
        for (x = 0; x < dw; x++) {
            float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f};
            for (k = 0; k < tx; k++) {
                const unsigned char *p = px + ((size_t)y * w + ix[(size_t)x * tx + k]) * 4;
                float wt = wx[(size_t)x * tx + k], a = p[3] * (1.0f / 255.0f);
                if (wt == 0.0f) continue;
                for (c = 0; c < 3; c++) acc[c] += wt * p[c] * a;
                acc[3] += wt * p[3];
            }
            memcpy(tmp + ((size_t)y * dw + x) * 4, acc, sizeof acc);
        }
    for (y = 0; y < dh; y++) /* vertical, then over the checkerboard */
        for (x = 0; x < dw; x++) {
            float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f}, a, bg;
            unsigned char *o = sheet + ((size_t)(y0 + y) * sw + (size_t)(x0 + x)) * 3;
            for (k = 0; k < ty; k++) {
                const float *p = tmp + ((size_t)iy[(size_t)y * ty + k] * dw + x) * 4;
                float wt = wy[(size_t)y * ty + k];
                for (c = 0; c < 4; c++) acc[c] += wt * p[c];
            }
            a = acc[3] * (1.0f / 255.0f);
            a = a < 0.0f ? 0.0f : a > 1.0f ? 1.0f : a;
            bg = ((x / q + y / q) & 1) ? 204.0f : 244.0f;
            for (c = 0; c < 3; c++) {
                float v = acc[c] + (1.0f - a) * bg;
                o[c] = (unsigned char)(v < 0.0f ? 0 : v > 255.0f ? 255 : (int)(v + 0.5f));
            }
        }
    rc = CLI_OK;
done:
    if (rc != CLI_OK) cli_error("out of memory resizing a %dx%d image", w, h);
    free(ix); free(wx); free(iy); free(wy); free(tmp);
    return rc;
}

/* the number of comma-separated entries of s */
static int cli_count_commas(const char *s) {
    int n = 1;
    for (; *s; s++) n += *s == ',';
    return n;
}

/* splits s (modified) at its commas into out[cli_count_commas(s)] */
static void cli_split_commas(char *s, char **out) {
    int n = 0;
    for (;;) {
        char *e = strchr(s, ',');
        out[n++] = s;
        if (!e) break;
        *e = 0;
        s = e + 1;
    }
}

/* FILE:r / :g / :b / :a (when no file has that very name): one channel, shown as gray. Cuts the suffix off
   name and returns where (put ':' back there), with *pick the channel; NULL (and *pick -1) for a plain name. */
static char *cli_sheet_channel(char *name, int *pick) {
    size_t len = strlen(name);
    *pick = -1;
    if (len < 3 || name[len - 2] != ':' || !name[len - 1] || !strchr("rgba", name[len - 1]) || cli_is_file(name)) return NULL;
    *pick = (int)(strchr("rgba", name[len - 1]) - "rgba");
    name[len - 2] = 0;
    return name + len - 2;
}

static int cli_sheet(int argc, char **argv) {
    const char *cmd = "sheet", *v, *out_path = NULL, *labels_arg = NULL, **row_args;
    int cell = 128, m, r, c, nrows = 0, ncols = 0, nlabels = 0, rc = CLI_OK, s, label_h, sw, sh, q;
    char **row_bufs = NULL, ***cells = NULL, *labels_buf = NULL, **labels = NULL;
    int *row_len = NULL;
    unsigned char *sheet = NULL;
    size_t npx;
    cli_argp P;

    row_args = (const char **)malloc(sizeof(char *) * (size_t)(argc > 0 ? argc : 1));
    if (!row_args) { cli_error("out of memory"); return CLI_FAIL; }
    cli_argp_init(&P, cmd, cli_opts_sheet, argc, argv, 2);
    while ((m = cli_argp_next(&P, &v)) != CLI_ARG_END) {
        if (m == CLI_ARG_HELP) { cli_help_print(stdout, cli_opts_sheet); free(row_args); return CLI_OK; }
        if (m == CLI_ARG_ERROR) { free(row_args); return CLI_USAGE; }
        if (m == CLI_ARG_OPERAND) row_args[nrows++] = v;
        else if (m == CLI_SHEET_OUT) out_path = v;
        else if (m == CLI_SHEET_LABELS) labels_arg = v;
        else if (m == CLI_SHEET_CELL && cli_parse_int(cmd, "--cell", v, 8, 1024, &cell)) { free(row_args); return CLI_USAGE; }
    }
    if (!out_path) { free(row_args); return cli_usage_error(cmd, "--out SHEET.png is required"); }
    if (!nrows) { free(row_args); return cli_usage_error(cmd, "no rows: give one or more ROWs, each a comma list of images (- for an empty cell)"); }

    /* the rows, split at commas */
    row_bufs = (char **)calloc((size_t)nrows, sizeof *row_bufs);
    cells = (char ***)calloc((size_t)nrows, sizeof *cells);
    row_len = (int *)calloc((size_t)nrows, sizeof *row_len);
    if (!row_bufs || !cells || !row_len) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
    for (r = 0; r < nrows; r++) {
        int n;
        row_bufs[r] = (char *)malloc(strlen(row_args[r]) + 1);
        if (!row_bufs[r]) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        strcpy(row_bufs[r], row_args[r]);
        n = cli_count_commas(row_bufs[r]);
        cells[r] = (char **)malloc(sizeof(char *) * (size_t)n);
        if (!cells[r]) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        cli_split_commas(row_bufs[r], cells[r]);
        row_len[r] = n;
        for (c = 0; c < n; c++)
            if (!cells[r][c][0]) {
                rc = cli_usage_error(cmd, "row %d ('%s'): entry %d is empty (use - for an empty cell)", r + 1, row_args[r], c + 1);
                goto done;
            }
        if (n > ncols) ncols = n;
    }
    if (labels_arg) {
        labels_buf = (char *)malloc(strlen(labels_arg) + 1);
        if (!labels_buf) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        strcpy(labels_buf, labels_arg);
        nlabels = cli_count_commas(labels_buf);
        if (nlabels > ncols) {
            rc = cli_usage_error(cmd, "--labels has %d titles but the sheet has %d column%s", nlabels, ncols, ncols == 1 ? "" : "s");
            goto done;
        }
        labels = (char **)malloc(sizeof(char *) * (size_t)nlabels);
        if (!labels) { cli_error("out of memory"); rc = CLI_FAIL; goto done; }
        cli_split_commas(labels_buf, labels);
    }

    /* the layout */
    s = 1 + cell / 256;
    label_h = labels ? 8 * s + CLI_SHEET_GUTTER : 0;
    if ((double)ncols * (cell + CLI_SHEET_GUTTER) + CLI_SHEET_GUTTER > 65535.0 ||
        (double)nrows * (cell + CLI_SHEET_GUTTER) + CLI_SHEET_GUTTER + label_h > 65535.0 ||
        ((double)ncols * (cell + CLI_SHEET_GUTTER) * 3.0 + 16.0) * ((double)nrows * (cell + CLI_SHEET_GUTTER) + 16.0 + label_h) > 1.0e9) {
        rc = cli_usage_error(cmd, "%d rows x %d columns of %d pixels are too large for one PNG: use a smaller --cell", nrows, ncols, cell);
        goto done;
    }
    sw = CLI_SHEET_GUTTER + ncols * (cell + CLI_SHEET_GUTTER);
    sh = CLI_SHEET_GUTTER + label_h + nrows * (cell + CLI_SHEET_GUTTER);
    q = cell / 16 > 4 ? cell / 16 : 4;

    /* every image readable before any work */
    for (r = 0; r < nrows; r++)
        for (c = 0; c < row_len[r]; c++) {
            int w, h, ch, pick, ok, deep;
            char *sel;
            if (!strcmp(cells[r][c], "-")) continue;
            sel = cli_sheet_channel(cells[r][c], &pick);
            ok = cli_pic_info(cells[r][c], "image", &w, &h, &ch, 0, &deep); /* 16 bits: shown at 8 */
            if (sel) *sel = ':';
            if (!ok) {
                rc = CLI_FAIL;
                goto done;
            }
        }

    npx = (size_t)sw * (size_t)sh;
    sheet = (unsigned char *)malloc(npx * 3);
    if (!sheet) { cli_error("out of memory for a %dx%d sheet", sw, sh); rc = CLI_FAIL; goto done; }
    memset(sheet, 255, npx * 3);
    for (c = 0; c < nlabels; c++) {
        int n = (int)strlen(labels[c]), fit = (cell + s) / (6 * s), tw;
        if (n > fit) n = fit;
        tw = n * 6 * s - s;
        cli_sheet_text(sheet, sw, sh, CLI_SHEET_GUTTER + c * (cell + CLI_SHEET_GUTTER) + (cell - tw) / 2, CLI_SHEET_GUTTER, labels[c], n, s);
    }
    for (r = 0; r < nrows && rc == CLI_OK; r++)
        for (c = 0; c < row_len[r] && rc == CLI_OK; c++) {
            int w = 0, h = 0, ch = 0, dw, dh, x0, y0;
            unsigned char *px;
            char *name = cells[r][c], *sel;
            int pick;
            if (!strcmp(name, "-")) continue;
            sel = cli_sheet_channel(name, &pick);
            px = cli_load(name, &w, &h, &ch, 4);
            if (!px) { cli_error("cannot read image '%s': %s", name, cli_stbi_reason()); rc = CLI_FAIL; break; }
            if (sel) {
                size_t k, n = (size_t)w * h;
                *sel = ':';
                for (k = 0; k < n; k++) {
                    unsigned char v = px[k * 4 + pick];
                    px[k * 4] = px[k * 4 + 1] = px[k * 4 + 2] = v;
                    px[k * 4 + 3] = 255;
                }
            }
            if (w >= h) { dw = cell; dh = (int)((double)cell * h / w + 0.5); }
            else { dh = cell; dw = (int)((double)cell * w / h + 0.5); }
            if (dw < 1) dw = 1;
            if (dh < 1) dh = 1;
            x0 = CLI_SHEET_GUTTER + c * (cell + CLI_SHEET_GUTTER) + (cell - dw) / 2;
            y0 = CLI_SHEET_GUTTER + label_h + r * (cell + CLI_SHEET_GUTTER) + (cell - dh) / 2;
            rc = cli_sheet_draw(sheet, sw, x0, y0, px, w, h, dw, dh, q);
            stbi_image_free(px);
        }
    if (rc == CLI_OK) rc = cli_write_png_u8(out_path, sheet, sw, sh, 3);
    if (rc == CLI_OK) printf("wrote %s (%dx%d: %d row%s, %d column%s of %d pixels)\n", out_path, sw, sh, nrows, nrows == 1 ? "" : "s",
                             ncols, ncols == 1 ? "" : "s", cell);

done:
    if (row_bufs) for (r = 0; r < nrows; r++) free(row_bufs[r]);
    if (cells) for (r = 0; r < nrows; r++) free(cells[r]);
    free(row_bufs); free(cells); free(row_len); free(labels_buf); free(labels); free(sheet); free(row_args);
    return rc;
}
