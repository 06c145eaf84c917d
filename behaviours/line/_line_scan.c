/* The line tracker's scan of its rows, in one pass per row: the per-pixel score of the wanted
 * colour against the floor, its 3-tap sums, and the runs above the level.
 *
 * behaviours/line/scan.py holds the same computation in numpy/OpenCV (used when this module
 * was not built) and says what each step is for; tests/behaviours/test_line_scan.py checks
 * that the two agree. The numpy version is ~30 array calls on 8 short rows, each cheap but
 * each a trip through numpy's or OpenCV's machinery, which right after a camera capture runs
 * with cold caches; here it is one call.
 *
 * Floats as the numpy version has them: the score in float32, the block floor's blur sums in
 * double (as OpenCV's box filter), crossings in double. No -ffast-math: results must not
 * depend on the compiler's reordering.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

enum { KIND_DARK = 0, KIND_LIGHT = 1, KIND_CHROMA = 2 };
#define MAX(a, b) ((a) > (b) ? (a) : (b))
#define MIN(a, b) ((a) < (b) ? (a) : (b))
#define PAD 2 /* zero cells either side of a row's score: its sums end at 0 */

/* Block means of a row's value, rounded to whole grey levels as OpenCV's INTER_AREA resize
 * rounds them (half to even), at least 1: the score divides by the floor. */
static void block_means(const uint8_t *value, const int *edges, int blocks, float *out)
{
    for (int j = 0; j < blocks; j++) {
        long sum = 0;
        for (int x = edges[j]; x < edges[j + 1]; x++)
            sum += value[x];
        double mean = nearbyint((double)sum / (edges[j + 1] - edges[j]));
        out[j] = mean < 1.0 ? 1.0f : (float)mean;
    }
}

/* Max (or min) over a window of 2 * radius + 1 blocks, cut short at the row's ends (OpenCV's
 * dilate and erode with their default border). van Herk / Gil-Werman: the extremes from each
 * window-sized segment's start and to its end, so each value costs three comparisons.
 * scratch: 3 * (n + 2 * radius) floats. */
static void window_extreme(const float *in, float *out, int n, int radius, int take_max,
                           float *scratch)
{
    const int k = 2 * radius + 1, m = n + 2 * radius;
    const float edge = take_max ? -FLT_MAX : FLT_MAX;
    float *padded = scratch, *from_start = scratch + m, *to_end = scratch + 2 * m;
    for (int i = 0; i < m; i++)
        padded[i] = i < radius || i >= radius + n ? edge : in[i - radius];
    for (int i = 0; i < m; i++) {
        float v = padded[i];
        if (i % k == 0) {
            from_start[i] = v;
        } else {
            float prev = from_start[i - 1];
            from_start[i] = take_max ? (v > prev ? v : prev) : (v < prev ? v : prev);
        }
    }
    for (int i = m - 1; i >= 0; i--) {
        float v = padded[i];
        if (i == m - 1 || (i + 1) % k == 0) {
            to_end[i] = v;
        } else {
            float next = to_end[i + 1];
            to_end[i] = take_max ? (v > next ? v : next) : (v < next ? v : next);
        }
    }
    for (int j = 0; j < n; j++) {
        float a = to_end[j], b = from_start[j + k - 1];
        out[j] = take_max ? (a > b ? a : b) : (a < b ? a : b);
    }
}

/* Mean of each block and its neighbours, mirrored at the ends (OpenCV's blur, 3 x 1, with
 * BORDER_REFLECT_101; n >= 2). */
static void blur3(const float *in, float *out, int n)
{
    for (int j = 0; j < n; j++) {
        double left = in[j > 0 ? j - 1 : 1];
        double right = in[j < n - 1 ? j + 1 : n - 2];
        out[j] = (float)((left + in[j] + right) * (1.0 / 3.0));
    }
}

/* The floor along a row without a dark (closing: take_max first) or bright line. */
static void background(const float *coarse, float *tmp, float *morphed, float *out, int blocks,
                       int radius, int closing, float *scratch)
{
    window_extreme(coarse, tmp, blocks, radius, closing, scratch);
    window_extreme(tmp, morphed, blocks, radius, !closing, scratch);
    blur3(morphed, out, blocks);
}

/* Each pixel's value (its brightest channel) and tint (its channel spread beyond grey_tint). */
static void value_and_tint(const uint8_t *restrict px, uint8_t *restrict value,
                           uint8_t *restrict tint, int width, int grey_tint)
{
    for (int x = 0; x < width; x++) {
        const uint8_t b = px[3 * x], g = px[3 * x + 1], r = px[3 * x + 2];
        const uint8_t hi = MAX(MAX(b, g), r), lo = MIN(MIN(b, g), r);
        const int spread = hi - lo - grey_tint;
        value[x] = hi;
        tint[x] = (uint8_t)(spread > 0 ? spread : 0);
    }
}

/* Each pixel's score against its block's floor; returns the floor summed over the pixels. */
static double score_row(const uint8_t *restrict px, const uint8_t *restrict value,
                        const uint8_t *restrict tint, const float *floor_px, const float *bright,
                        const int *edges, int blocks, int kind, int wanted_mask,
                        int others_mask, float *restrict cell)
{
    double floor_sum = 0.0;
    for (int j = 0; j < blocks; j++) {
        const float f = floor_px[j], lit = bright[j];
        const int x0 = edges[j], x1 = edges[j + 1];
        floor_sum += (double)f * (x1 - x0);
        if (kind == KIND_DARK) {
            for (int x = x0; x < x1; x++)
                cell[x] = (f - (float)(value[x] + tint[x])) / f;
        } else if (kind == KIND_LIGHT) {
            for (int x = x0; x < x1; x++)
                cell[x] = ((float)(value[x] - tint[x]) - lit) / f;
        } else {
            for (int x = x0; x < x1; x++) {
                const uint8_t *p = px + 3 * x;
                int wanted = 255, others = 0;
                for (int c = 0; c < 3; c++) {
                    if (wanted_mask >> c & 1 && p[c] < wanted)
                        wanted = p[c];
                    if (others_mask >> c & 1 && p[c] > others)
                        others = p[c];
                }
                cell[x] = ((float)wanted - (float)others) / f;
            }
        }
    }
    return floor_sum;
}

/* Each cell plus its neighbours either side (cells 1 .. span - 2; the ends stay 0). */
static void three_tap(const float *restrict score, float *restrict sums, int span)
{
    for (int i = 1; i < span - 1; i++)
        sums[i] = (score[i - 1] + score[i]) + score[i + 1];
}

typedef struct {
    PyObject *runs; /* list of (row, begin, end, middle, mass) */
    const float *sums;
    double level;
    Py_ssize_t row;
    int begin, end; /* cells of the pending run; begin < 0: none */
} RunList;

static int emit(RunList *list)
{
    if (list->begin < 0)
        return 0;
    const float *s = list->sums;
    int b = list->begin, e = list->end;
    double mass = 0.0;
    for (int i = b; i < e; i++)
        mass += s[i];
    double cross_begin = (b - 1) + (list->level - s[b - 1]) / ((double)s[b] - s[b - 1]);
    double cross_end = (e - 1) + (list->level - s[e - 1]) / ((double)s[e] - s[e - 1]);
    PyObject *run = Py_BuildValue("(niidd)", list->row, b - PAD, e - PAD,
                                  (cross_begin + cross_end) / 2 - PAD, mass);
    list->begin = -1;
    if (run == NULL)
        return -1;
    int failed = PyList_Append(list->runs, run);
    Py_DECREF(run);
    return failed;
}

/* Runs of sums above the level in one row (cells 1 .. span - 2; the ends are 0), runs split
 * by gaps of up to gap_px cells joined. */
static int find_runs(RunList *list, int span, int gap_px)
{
    const float *s = list->sums;
    float level = (float)list->level; /* compared in float32, as numpy compares */
    int i = 1;
    while (i < span - 1) {
        if (!(s[i] > level)) {
            i++;
            continue;
        }
        int b = i;
        while (s[i] > level)
            i++;
        if (list->begin >= 0 && b - list->end <= gap_px) {
            list->end = i;
            continue;
        }
        if (emit(list) < 0)
            return -1;
        list->begin = b;
        list->end = i;
    }
    return emit(list);
}

/* The row indices, copied out of the sequence before anything else, each item fetched with
 * its bounds checked: a list can change under us while Python code runs (an __index__, a
 * finalizer run by the garbage collector). NULL with an exception set. */
static Py_ssize_t *read_rows(PyObject *rows_obj, Py_ssize_t *count)
{
    if (!PySequence_Check(rows_obj) || PyUnicode_Check(rows_obj)) {
        PyErr_SetString(PyExc_TypeError, "line scan: rows must be a sequence of row indices");
        return NULL;
    }
    Py_ssize_t n = PySequence_Size(rows_obj);
    if (n < 0)
        return NULL;
    Py_ssize_t *rows = PyMem_Malloc(sizeof(Py_ssize_t) * (size_t)(n ? n : 1));
    if (rows == NULL) {
        PyErr_NoMemory();
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PySequence_GetItem(rows_obj, i); /* IndexError if it shrank */
        if (item == NULL)
            goto fail;
        if (PyBool_Check(item) || !PyIndex_Check(item)) {
            PyErr_Format(PyExc_TypeError, "line scan: rows[%zd] is %.100s, not a row index", i,
                         Py_TYPE(item)->tp_name);
            Py_DECREF(item);
            goto fail;
        }
        rows[i] = PyNumber_AsSsize_t(item, PyExc_IndexError);
        Py_DECREF(item);
        if (rows[i] == -1 && PyErr_Occurred())
            goto fail;
    }
    *count = n;
    return rows;
fail:
    PyMem_Free(rows);
    return NULL;
}

static PyObject *scan(PyObject *self, PyObject *args)
{
    PyObject *image_obj, *rows_obj;
    int kind, wanted_mask, others_mask, grey_tint, blocks, radius, gap_px;
    double level;
    (void)self;
    if (!PyArg_ParseTuple(args, "OOiiidiiii", &image_obj, &rows_obj, &kind, &wanted_mask,
                          &others_mask, &level, &grey_tint, &blocks, &radius, &gap_px))
        return NULL;
    Py_ssize_t count;
    Py_ssize_t *rows = read_rows(rows_obj, &count);
    if (rows == NULL)
        return NULL;
    Py_buffer view;
    if (PyObject_GetBuffer(image_obj, &view, PyBUF_STRIDES | PyBUF_FORMAT) < 0) {
        PyMem_Free(rows);
        return NULL;
    }
    PyObject *result = NULL, *runs = NULL;
    uint8_t *value = NULL;
    float *work = NULL;
    int *edges = NULL;
    if (view.ndim != 3 || view.itemsize != 1 || (view.format && strcmp(view.format, "B")) ||
        view.shape[2] != 3 || view.strides[2] != 1 || view.strides[1] != 3 ||
        view.shape[1] < 4 || view.shape[1] > 1 << 20) {
        PyErr_SetString(PyExc_ValueError,
                        "line scan: expected uint8 BGR rows (h, w, 3), 4 <= w <= 2**20, "
                        "pixels packed");
        goto done;
    }
    if (kind < KIND_DARK || kind > KIND_CHROMA || blocks < 2 || blocks > view.shape[1] ||
        radius < 0 || radius > blocks || grey_tint < 0 || grey_tint > 255 || !(level > 0.0)) {
        PyErr_SetString(PyExc_ValueError,
                        "line scan: bad kind, block count, radius, grey tint or level");
        goto done;
    }
    const Py_ssize_t height = view.shape[0];
    for (Py_ssize_t r = 0; r < count; r++) {
        if (rows[r] < 0 || rows[r] >= height) {
            PyErr_Format(PyExc_IndexError,
                         "line scan: row %zd (rows[%zd]) outside the image's 0..%zd", rows[r],
                         r, height - 1);
            goto done;
        }
    }
    const int width = (int)view.shape[1];
    const int span = width + 2 * PAD;
    value = malloc((size_t)width * 2);
    work = malloc(sizeof(float) * ((size_t)blocks * 8 + (size_t)radius * 6 + (size_t)span * 2));
    edges = malloc(sizeof(int) * ((size_t)blocks + 1));
    runs = PyList_New(0);
    if (value == NULL || work == NULL || edges == NULL || runs == NULL) {
        if (!PyErr_Occurred())
            PyErr_NoMemory();
        goto done;
    }
    uint8_t *tint = value + width;
    float *coarse = work, *tmp = work + blocks, *morphed = work + 2 * blocks;
    float *floor_px = work + 3 * blocks, *bright = work + 4 * blocks;
    float *score = work + 5 * blocks, *sums = score + span, *scratch = sums + span;
    for (int j = 0; j <= blocks; j++) /* as np.round(np.linspace(0, width, blocks + 1)) */
        edges[j] = (int)nearbyint(j * ((double)width / blocks));
    memset(score, 0, sizeof(float) * (size_t)span);
    memset(sums, 0, sizeof(float) * (size_t)span);
    memset(bright, 0, sizeof(float) * (size_t)blocks); /* read, not used, unless light */
    RunList list = {runs, sums, level, 0, -1, 0};
    double floor_sum = 0.0;
    for (Py_ssize_t r = 0; r < count; r++) {
        const uint8_t *px = (const uint8_t *)view.buf + rows[r] * view.strides[0];
        value_and_tint(px, value, tint, width, grey_tint);
        block_means(value, edges, blocks, coarse);
        background(coarse, tmp, morphed, floor_px, blocks, radius, 1, scratch);
        if (kind == KIND_LIGHT)
            background(coarse, tmp, morphed, bright, blocks, radius, 0, scratch);
        floor_sum += score_row(px, value, tint, floor_px, bright, edges, blocks, kind,
                               wanted_mask, others_mask, score + PAD);
        three_tap(score, sums, span);
        list.row = r;
        if (find_runs(&list, span, gap_px) < 0)
            goto done;
    }
    result = Py_BuildValue("(dO)", count ? floor_sum / ((double)count * width) : 0.0, runs);
done:
    free(value);
    free(work);
    free(edges);
    Py_XDECREF(runs);
    PyMem_Free(rows);
    PyBuffer_Release(&view);
    return result;
}

static PyMethodDef methods[] = {
    {"scan", scan, METH_VARARGS,
     "scan(image, rows, kind, wanted_mask, others_mask, level, grey_tint, blocks, radius, "
     "gap_px) -> (floor_mean, [(row, begin, end, middle, mass), ...])"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "behaviours.line._line_scan",
    "The line tracker's row scan in C; see behaviours/line/scan.py.", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__line_scan(void)
{
    return PyModule_Create(&module);
}
