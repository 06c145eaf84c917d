/* The simulated line camera's last step in one pass: light the painted floor and add sensor
 * noise (hal/sim/devices/camera_model.py, SimCamera._render_shot).
 *
 * The same arithmetic as the OpenCV calls it replaces, so frames are the same to the bit:
 *   gain = (texture * static_gain) * ambient            float32, as two cv2.multiply
 *   lit  = float(paint) * gain                          float32, cv2.multiply(u8, f32, CV_32F)
 *   out  = saturate(round_half_even(lit) + noise)       cv2.add(f32, i8, dtype=CV_8U)
 * (for an integer result with one float input, OpenCV rounds that input to an integer first,
 * then adds in int32).
 * Built with -ffp-contract=off: a fused multiply-add rounds once where OpenCV rounds twice.
 * No -ffast-math. The Python fallback (the OpenCV calls) is used when this was not built.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdint.h>
#include <string.h>

/* Adding then subtracting 2**23 rounds a float in [0, 2**22) to the nearest integer, ties to
 * even (the default rounding mode), as OpenCV's cvRound does. The caller guarantees that
 * range: paint is >= 0 and every gain factor > 0 and bounded (camera_model.py checks). */
#define ROUND_MAGIC 8388608.0f

/* x86-64's baseline (SSE2) converts between bytes, ints and floats one lane at a time; where
 * the CPU has AVX2 the loader picks a build of this function that uses it (2x faster). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
static void light_rows(const uint8_t *paint, const float *tex, const float *stat,
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
        /* One flat loop over the row's 3w values: the compiler vectorizes it. */
        const uint8_t *p = paint + at * 3;
        const int8_t *n = noise + r * noise_row;
        uint8_t *o = out + at * 3;
        for (Py_ssize_t i = 0; i < 3 * w; i++) {
            const float lit = (float)p[i] * gain3[i];
            const int x = (int)((lit + ROUND_MAGIC) - ROUND_MAGIC) + n[i];
            o[i] = (uint8_t)(x < 0 ? 0 : (x > 255 ? 255 : x));
        }
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

static PyObject *light(PyObject *self, PyObject *args)
{
    PyObject *objs[6];
    int oy, ox;
    (void)self;
    if (!PyArg_ParseTuple(args, "OOOOOiiO", &objs[0], &objs[1], &objs[2], &objs[3], &objs[4],
                          &oy, &ox, &objs[5]))
        return NULL;
    static const char *const names[6] = {"paint", "texture", "static gain", "ambient",
                                         "noise", "out"};
    static const int ndims[6] = {3, 2, 2, 2, 3, 3};
    static const char *const formats[6] = {"B", "f", "f", "f", "b", "B"};
    Py_buffer v[6];
    int got = 0;
    PyObject *result = NULL;
    for (; got < 6; got++) {
        if (get(objs[got], &v[got], got == 5 ? PyBUF_WRITABLE : 0, ndims[got], formats[got],
                names[got]) < 0)
            goto done;
    }
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
    light_rows(paint, tex, stat, amb, noise + (Py_ssize_t)oy * noise_row + (Py_ssize_t)ox * 3,
               noise_row, out, h, w, gain3);
    Py_END_ALLOW_THREADS
    PyMem_Free(gain3);
    result = Py_NewRef(Py_None);
done:
    while (got-- > 0)
        PyBuffer_Release(&v[got]);
    return result;
}

static PyMethodDef methods[] = {
    {"light", light, METH_VARARGS,
     "light(paint, texture, static_gain, ambient, noise, noise_row, noise_col, out) -> None"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "hal.sim.devices._camera_light",
    "The simulated camera's lighting and noise in C; see hal/sim/devices/camera_model.py.", -1,
    methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__camera_light(void)
{
    return PyModule_Create(&module);
}
