/* The simulated line camera's last step in one pass: light the painted floor and add sensor
 * noise (sim/devices/camera_model.py, SimCamera._render_shot), for the whole frame
 * (light) or for some of its rows (light_rows: the rows the line tracker reads).
 *
 * The same arithmetic as the OpenCV calls it replaces, so frames are the same to the bit:
 *   gain = (texture * static_gain) * ambient            float32, as two cv2.multiply
 *   lit  = float(paint) * gain                          float32, cv2.multiply(u8, f32, CV_32F)
 *   out  = saturate(round_half_even(lit) + noise)       cv2.add(f32, i8, dtype=CV_8U)
 * (for an integer result with one float input, OpenCV rounds that input to an integer first,
 * then adds in int32).
 * light_rows also looks the floor texture up itself, as OpenCV 5's
 * warpAffine(INTER_NEAREST | WARP_INVERSE_MAP, BORDER_REFLECT) does: the matrix in float32,
 * each source coordinate fma(M[0], x, M[1] * y + M[2]) in float32, rounded half to even.
 * Built with -ffp-contract=off: a fused multiply-add rounds once where OpenCV rounds twice
 * (the texture's fma is an explicit fmaf, as OpenCV's). No -ffast-math. The Python fallback
 * (the OpenCV calls) is used when this was not built.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stdint.h>
#include <string.h>

/* Adding then subtracting 2**23 rounds a float in [0, 2**22) to the nearest integer, ties to
 * even (the default rounding mode), as OpenCV's cvRound does. The caller guarantees that
 * range: paint is >= 0 and every gain factor > 0 and bounded (camera_model.py checks). */
#define ROUND_MAGIC 8388608.0f

/* One row: each pixel's gain already in gain3 (three times over), lit and noised into out. */
static inline void light_row(const uint8_t *p, const float *gain3, const int8_t *n, uint8_t *o,
                             Py_ssize_t w)
{
    /* One flat loop over the row's 3w values: the compiler vectorizes it. */
    for (Py_ssize_t i = 0; i < 3 * w; i++) {
        const float lit = (float)p[i] * gain3[i];
        const int x = (int)((lit + ROUND_MAGIC) - ROUND_MAGIC) + n[i];
        o[i] = (uint8_t)(x < 0 ? 0 : (x > 255 ? 255 : x));
    }
}

/* x86-64's baseline (SSE2) converts between bytes, ints and floats one lane at a time; where
 * the CPU has AVX2 the loader picks a build of this function that uses it (2x faster). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
static void light_frame(const uint8_t *paint, const float *tex, const float *stat,
                        const float *amb, const int8_t *noise, Py_ssize_t noise_row,
                        uint8_t *out, Py_ssize_t h, Py_ssize_t w, float *gain3)
{
    for (Py_ssize_t r = 0; r < h; r++) {
        const Py_ssize_t at = r * w;
        for (Py_ssize_t c = 0; c < w; c++) {
            const float g = (tex[at + c] * stat[at + c]) * amb[at + c];
            gain3[3 * c] = g;
            gain3[3 * c + 1] = g;
            gain3[3 * c + 2] = g;
        }
        light_row(paint + at * 3, gain3, noise + r * noise_row, out + at * 3, w);
    }
}

/* BORDER_REFLECT (fedcba|abcdefgh|hgfedcb) of an index into 0 .. n - 1. */
static inline Py_ssize_t reflect(Py_ssize_t i, Py_ssize_t n)
{
    while (i < 0 || i >= n) {
        if (i < 0)
            i = -i - 1;
        else
            i = 2 * n - i - 1;
    }
    return i;
}

/* A float rounded to the nearest integer, ties to even (as lrintf, without a libm call):
 * adding and subtracting 1.5 * 2**23 does it for |v| < 2**22. */
static inline Py_ssize_t round_index(float v)
{
    if (!(fabsf(v) < 4194304.0f))
        return (Py_ssize_t)nearbyintf(v); /* never for a texture the view fits in */
    return (Py_ssize_t)((v + 12582912.0f) - 12582912.0f);
}

/* Rows rows[0..k-1] of the frame, the texture looked up for them (see the top); ambient holds
 * the room light of those rows only. Where the CPU has FMA the loader picks a build whose
 * fmaf is one instruction (2x faster than libm's call, which gives the same result). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("fma", "default")))
#endif
static void light_some_rows(const uint8_t *paint, const float *texture, Py_ssize_t tex_h,
                            Py_ssize_t tex_w, const float *m, const float *stat,
                            const float *amb, const int8_t *noise, Py_ssize_t noise_row,
                            const Py_ssize_t *rows, Py_ssize_t k, uint8_t *out, Py_ssize_t w,
                            float *gain3)
{
    for (Py_ssize_t i = 0; i < k; i++) {
        const Py_ssize_t r = rows[i], at = r * w;
        const float y = (float)r;
        const float bx = m[1] * y + m[2], by = m[4] * y + m[5];
        const float *a = amb + i * w;
        for (Py_ssize_t c = 0; c < w; c++) {
            const float x = (float)c;
            const Py_ssize_t sx = reflect(round_index(fmaf(m[0], x, bx)), tex_w);
            const Py_ssize_t sy = reflect(round_index(fmaf(m[3], x, by)), tex_h);
            const float g = (texture[sy * tex_w + sx] * stat[at + c]) * a[c];
            gain3[3 * c] = g;
            gain3[3 * c + 1] = g;
            gain3[3 * c + 2] = g;
        }
        light_row(paint + at * 3, gain3, noise + r * noise_row, out + i * w * 3, w);
    }
}

static int get(PyObject *obj, Py_buffer *view, int flags, int ndim, const char *format,
               const char *what)
{
    if (PyObject_GetBuffer(obj, view, flags | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return -1;
    if (view->ndim != ndim || (view->format && strcmp(view->format, format))) {
        PyErr_Format(PyExc_ValueError, "camera light: %s must be a C-contiguous %dD array of "
                     "'%s'", what, ndim, format);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

static void release(Py_buffer *views, int count)
{
    while (count-- > 0)
        PyBuffer_Release(&views[count]);
}

/* The six arrays light() and light_rows() take, in this order: paint, texture, static gain,
 * ambient, noise, out (writable). Returns how many were got: 6, or fewer with an exception set
 * (the caller releases that many). */
static int get_frame_buffers(PyObject *const objs[6], Py_buffer views[6])
{
    static const char *const names[6] = {"paint", "texture", "static gain", "ambient",
                                         "noise", "out"};
    static const int ndims[6] = {3, 2, 2, 2, 3, 3};
    static const char *const formats[6] = {"B", "f", "f", "f", "b", "B"};
    int got = 0;
    for (; got < 6; got++) {
        if (get(objs[got], &views[got], got == 5 ? PyBUF_WRITABLE : 0, ndims[got],
                formats[got], names[got]) < 0)
            break;
    }
    return got;
}

static PyObject *light(PyObject *self, PyObject *args)
{
    PyObject *objs[6];
    int oy, ox;
    (void)self;
    if (!PyArg_ParseTuple(args, "OOOOOiiO", &objs[0], &objs[1], &objs[2], &objs[3], &objs[4],
                          &oy, &ox, &objs[5]))
        return NULL;
    Py_buffer v[6];
    PyObject *result = NULL;
    const int got = get_frame_buffers(objs, v);
    if (got < 6)
        goto done;
    const Py_ssize_t h = v[0].shape[0], w = v[0].shape[1];
    int ok = v[0].shape[2] == 3 && v[4].shape[2] == 3 && v[5].shape[2] == 3
             && v[5].shape[0] == h && v[5].shape[1] == w;
    for (int i = 1; i < 4; i++)
        ok = ok && v[i].shape[0] == h && v[i].shape[1] == w;
    ok = ok && oy >= 0 && ox >= 0 && oy + h <= v[4].shape[0] && ox + w <= v[4].shape[1];
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "camera light: shapes differ (paint (h, w, 3); "
                        "texture, static gain, ambient (h, w); out (h, w, 3); noise holds "
                        "(h, w, 3) at the offset)");
        goto done;
    }
    const uint8_t *paint = v[0].buf;
    const float *tex = v[1].buf, *stat = v[2].buf, *amb = v[3].buf;
    const int8_t *noise = v[4].buf;
    uint8_t *out = v[5].buf;
    const Py_ssize_t noise_row = v[4].shape[1] * 3;
    float *gain3 = PyMem_Malloc(sizeof(float) * (size_t)w * 3);
    if (gain3 == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    light_frame(paint, tex, stat, amb, noise + (Py_ssize_t)oy * noise_row + (Py_ssize_t)ox * 3,
                noise_row, out, h, w, gain3);
    Py_END_ALLOW_THREADS
    PyMem_Free(gain3);
    result = Py_NewRef(Py_None);
done:
    release(v, got);
    return result;
}

/* light_rows(paint, texture, matrix, static_gain, ambient, noise, noise_row, noise_col, rows,
 * out): rows ``rows`` of the frame light() would draw with the texture cv2.warpAffine(texture,
 * matrix, ...) would give, into out (len(rows), w, 3); ambient has those rows' room light. */
static PyObject *light_rows(PyObject *self, PyObject *args)
{
    PyObject *objs[6], *rows_obj;
    float m[6];
    int oy, ox;
    (void)self;
    if (!PyArg_ParseTuple(args, "OO(ffffff)OOOiiOO", &objs[0], &objs[1], &m[0], &m[1], &m[2],
                          &m[3], &m[4], &m[5], &objs[2], &objs[3], &objs[4], &oy, &ox,
                          &rows_obj, &objs[5]))
        return NULL;
    Py_buffer v[6];
    PyObject *result = NULL;
    Py_ssize_t *rows = NULL;
    float *gain3 = NULL;
    PyObject *seq = PySequence_Fast(rows_obj, "camera light: rows must be a sequence of ints");
    if (seq == NULL)
        return NULL;
    const int got = get_frame_buffers(objs, v);
    if (got < 6)
        goto done;
    const Py_ssize_t h = v[0].shape[0], w = v[0].shape[1], k = PySequence_Fast_GET_SIZE(seq);
    int ok = v[0].shape[2] == 3 && v[4].shape[2] == 3 && v[5].shape[2] == 3
             && v[5].shape[0] == k && v[5].shape[1] == w && v[1].shape[0] > 0
             && v[1].shape[1] > 0;
    ok = ok && v[2].shape[0] == h && v[2].shape[1] == w && v[3].shape[0] == k
         && v[3].shape[1] == w;
    ok = ok && oy >= 0 && ox >= 0 && oy + h <= v[4].shape[0] && ox + w <= v[4].shape[1];
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "camera light: shapes differ (paint (h, w, 3); "
                        "static gain (h, w); ambient (len(rows), w); out (len(rows), w, 3); "
                        "noise holds (h, w, 3) at the offset; texture not empty)");
        goto done;
    }
    rows = PyMem_Malloc(sizeof(Py_ssize_t) * (size_t)(k ? k : 1));
    gain3 = PyMem_Malloc(sizeof(float) * (size_t)w * 3);
    if (rows == NULL || gain3 == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t i = 0; i < k; i++) {
        rows[i] = PyNumber_AsSsize_t(PySequence_Fast_GET_ITEM(seq, i), PyExc_IndexError);
        if (rows[i] == -1 && PyErr_Occurred())
            goto done;
        if (rows[i] < 0 || rows[i] >= h) {
            PyErr_Format(PyExc_IndexError, "camera light: row %zd (rows[%zd]) outside the "
                         "frame's 0..%zd", rows[i], i, h - 1);
            goto done;
        }
    }
    const Py_ssize_t noise_row = v[4].shape[1] * 3;
    Py_BEGIN_ALLOW_THREADS
    light_some_rows(v[0].buf, v[1].buf, v[1].shape[0], v[1].shape[1], m, v[2].buf, v[3].buf,
                    (const int8_t *)v[4].buf + (Py_ssize_t)oy * noise_row + (Py_ssize_t)ox * 3,
                    noise_row, rows, k, v[5].buf, w, gain3);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(rows);
    PyMem_Free(gain3);
    release(v, got);
    Py_DECREF(seq);
    return result;
}

/* ambient_coarse(fwd, left, x, y, c, s, phases, variation, out): the room light's field on the
 * coarse grid (fwd, left: float64 (gh, gw), the grid's points in the robot's frame) seen from
 * the pose (x, y, c = cos heading, s = sin heading), into out (float64 (gh, gw)): each value
 * rounded to float32 and back, as FloorLight._ambient_coarse's numpy steps give it (libm sin,
 * which numpy's float64 sin is: the module's user checks that at start). */
static PyObject *ambient_coarse(PyObject *self, PyObject *args)
{
    PyObject *objs[3];
    double x, y, c, s, p[4], variation;
    (void)self;
    if (!PyArg_ParseTuple(args, "OOdddd(dddd)dO", &objs[0], &objs[1], &x, &y, &c, &s, &p[0],
                          &p[1], &p[2], &p[3], &variation, &objs[2]))
        return NULL;
    static const char *const names[3] = {"fwd", "left", "out"};
    Py_buffer v[3];
    int got = 0;
    PyObject *result = NULL;
    for (; got < 3; got++) {
        if (get(objs[got], &v[got], got == 2 ? PyBUF_WRITABLE : 0, 2, "d", names[got]) < 0)
            goto done;
    }
    if (v[1].shape[0] != v[0].shape[0] || v[1].shape[1] != v[0].shape[1]
        || v[2].shape[0] != v[0].shape[0] || v[2].shape[1] != v[0].shape[1]) {
        PyErr_SetString(PyExc_ValueError, "camera light: fwd, left and out differ in shape");
        goto done;
    }
    const double *fwd = v[0].buf, *left = v[1].buf;
    double *out = v[2].buf;
    for (Py_ssize_t i = 0; i < v[0].shape[0] * v[0].shape[1]; i++) {
        /* pose.x_m + c * fwd - s * left; pose.y_m + s * fwd + c * left (numpy's order) */
        const double wx = (x + c * fwd[i]) - s * left[i];
        const double wy = (y + s * fwd[i]) + c * left[i];
        const double field = sin(wx * 2.1 + p[0]) * sin(wy * 1.7 + p[1])
                             + 0.5 * sin((wx * 5.3 + wy * 3.1) + p[2]);
        out[i] = (double)(float)(1.0 + variation * field / 1.5);
    }
    result = Py_NewRef(Py_None);
done:
    release(v, got);
    return result;
}

/* place_segments(ends, x, y, c, s, limit, half_w, half_h, m_per_px, forward_m, scale): the
 * segments (rows x1, y1, x2, y2 of the float64 array ends) of one painted line that come
 * within ``limit`` of the view's centre, placed in the image as SimCamera._draw_lines does in
 * Python (sim/devices/camera_model.py), to the bit: the same double operations in the same
 * order (SegmentSet.distances' projection, clip and libm hypot, which numpy's np.hypot calls;
 * the rotation into the robot's frame; pixels; round-half-even fixed point as Python's round()
 * is, nearbyint in the default rounding mode). Returns None when no segment is near, else
 * ([((col1, row1), (col2, row2)), ...] in fixed point for cv2.line, min col, min row,
 * max col, max row) over the ends' unrounded pixel positions. */
static PyObject *fixed_point(double v)
{
    return PyLong_FromDouble(nearbyint(v)); /* raises on NaN or inf as round() does */
}

static PyObject *place_segments(PyObject *self, PyObject *args)
{
    PyObject *ends_obj;
    double x, y, c, s, limit, half_w, half_h, mpp, forward, scale;
    (void)self;
    if (!PyArg_ParseTuple(args, "Odddddddddd", &ends_obj, &x, &y, &c, &s, &limit, &half_w,
                          &half_h, &mpp, &forward, &scale))
        return NULL;
    Py_buffer v;
    if (get(ends_obj, &v, 0, 2, "d", "ends") < 0)
        return NULL;
    PyObject *result = NULL, *placed = NULL;
    if (v.shape[1] != 4) {
        PyErr_SetString(PyExc_ValueError, "camera light: ends must be (n, 4): x1, y1, x2, y2");
        goto done;
    }
    const double *e = v.buf;
    const Py_ssize_t n = v.shape[0];
    /* The view's centre, as Pose.to_world(forward_m, 0.0). */
    const double cx = x + c * forward - s * 0.0, cy = y + s * forward + c * 0.0;
    double lo_col = 0, lo_row = 0, hi_col = 0, hi_row = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        const double x1 = e[4 * i], y1 = e[4 * i + 1], x2 = e[4 * i + 2], y2 = e[4 * i + 3];
        const double ex = x2 - x1, ey = y2 - y1, length2 = ex * ex + ey * ey;
        double t = 0.0;
        if (length2 > 0) {
            t = ((cx - x1) * ex + (cy - y1) * ey) / length2;
            t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
        }
        if (!(hypot(x1 + t * ex - cx, y1 + t * ey - cy) < limit))
            continue;
        if (placed == NULL && (placed = PyList_New(0)) == NULL)
            goto done;
        PyObject *pts[2] = {NULL, NULL};
        for (int k = 0; k < 2; k++) {
            const double dx = (k ? x2 : x1) - x, dy = (k ? y2 : y1) - y;
            const double fwd = c * dx + s * dy, left = -s * dx + c * dy;
            const double col = half_w - left / mpp - 0.5;
            const double row = half_h - (fwd - forward) / mpp - 0.5;
            const int first = PyList_GET_SIZE(placed) == 0 && k == 0;
            /* min()/max() over a list keep the first of equals: strict comparisons. */
            if (first || col < lo_col)
                lo_col = col;
            if (first || row < lo_row)
                lo_row = row;
            if (first || col > hi_col)
                hi_col = col;
            if (first || row > hi_row)
                hi_row = row;
            PyObject *pc = fixed_point(col * scale), *pr = pc ? fixed_point(row * scale) : NULL;
            pts[k] = pr ? PyTuple_Pack(2, pc, pr) : NULL;
            Py_XDECREF(pc);
            Py_XDECREF(pr);
            if (pts[k] == NULL) {
                Py_XDECREF(pts[0]);
                goto done;
            }
        }
        PyObject *pair = PyTuple_Pack(2, pts[0], pts[1]);
        Py_DECREF(pts[0]);
        Py_DECREF(pts[1]);
        if (pair == NULL || PyList_Append(placed, pair) < 0) {
            Py_XDECREF(pair);
            goto done;
        }
        Py_DECREF(pair);
    }
    if (placed == NULL)
        result = Py_NewRef(Py_None);
    else
        result = Py_BuildValue("(Odddd)", placed, lo_col, lo_row, hi_col, hi_row);
done:
    Py_XDECREF(placed);
    PyBuffer_Release(&v);
    return result;
}

static PyMethodDef methods[] = {
    {"light", light, METH_VARARGS,
     "light(paint, texture, static_gain, ambient, noise, noise_row, noise_col, out) -> None"},
    {"light_rows", light_rows, METH_VARARGS,
     "light_rows(paint, texture, matrix, static_gain, ambient, noise, noise_row, noise_col, "
     "rows, out) -> None"},
    {"ambient_coarse", ambient_coarse, METH_VARARGS,
     "ambient_coarse(fwd, left, x, y, c, s, phases, variation, out) -> None"},
    {"place_segments", place_segments, METH_VARARGS,
     "place_segments(ends, x, y, c, s, limit, half_w, half_h, m_per_px, forward_m, scale) -> "
     "None | (points, min_col, min_row, max_col, max_row)"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "sim.devices._camera_light",
    "The simulated camera's lighting and noise in C; see sim/devices/camera_model.py.", -1,
    methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__camera_light(void)
{
    return PyModule_Create(&module);
}
