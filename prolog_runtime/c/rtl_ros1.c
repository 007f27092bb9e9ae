/*  ROS 1 messages as event terms, in C (prolog_runtime/rtl_ros1.pl).

    A message comes as its ROS 1 serialized bytes (a Prolog string of codes 0..255) and
    the handle of a *schema*: the layout of its type and the term to build, which the
    Python driver derives once per type from the type's definition (retalisc/robot_io/
    ros1_terms.py) and registers with rtl_ros1_register/2. The term is the one the
    driver's text conversion gives (robot_io/messages.py): compounds named after the types,
    lists for arrays, [Sec, NSec] for times, atoms for strings and booleans.

    Schema terms (ground):
        f32 f64 i8 u8 i16 u16 i32 u32 i64 u64 bool   numbers and booleans
        rs ps                                        strings: the release's '"text"' / 'text'
        m(Functor, [S, ...])                         a message: Functor(...), or the atom
                                                     Functor when it has no fields
        tl([S, ...])                                 fields read into a list ([Sec, NSec])
        a(N, S)  q(S)                                arrays of N / of a uint32 count
        w(Functor, S)                                Functor(S): the topic wrapper
        cdr(S)                                       at the top only: the bytes are ROS 2's
                                                     CDR (little endian, its 4-byte
                                                     encapsulation header first), S read with
                                                     CDR's alignment (a value of N bytes at a
                                                     multiple of min(N, 8) from the payload's
                                                     start, counts and string lengths at a
                                                     multiple of 4, a string's length counting
                                                     its final NUL, a message without fields
                                                     one byte), up to 3 zero bytes of padding
                                                     after it

    rtl_ros1_term/3 fails, leaving the driver's conversion to read the message and say
    what is wrong with it, when the bytes do not hold exactly one message of the type
    (too short, trailing bytes), when a string is not UTF-8, or when a float is not
    finite (the text conversion writes those). Nothing of the bytes is trusted: every
    read is bounds-checked.
*/

#include <SWI-Prolog.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

enum kind { K_F32, K_F64, K_I8, K_U8, K_I16, K_U16, K_I32, K_U32, K_I64, K_U64, K_BOOL,
            K_RSTR, K_PSTR, K_MSG, K_TLIST, K_ARRAY, K_SEQ, K_WRAP, K_CDR };

typedef struct node {
    enum kind kind;
    atom_t name;                /* K_MSG without fields: the atom; K_MSG, K_WRAP: functor name */
    functor_t functor;          /* K_MSG with fields, K_WRAP */
    size_t count;               /* children (K_MSG, K_TLIST); elements (K_ARRAY) */
    size_t min_size;            /* the fewest bytes a value takes */
    struct node **children;     /* K_ARRAY, K_SEQ, K_WRAP: children[0] */
} node;

#define MAX_SCHEMAS 4096
static node *schemas[MAX_SCHEMAS];
static size_t schema_count;
static pthread_mutex_t schema_lock = PTHREAD_MUTEX_INITIALIZER;

static atom_t a_true, a_false, a_m, a_tl, a_a, a_q, a_w, a_cdr;
static struct { const char *name; enum kind kind; atom_t atom; } bases[] = {
    {"f32", K_F32, 0}, {"f64", K_F64, 0}, {"i8", K_I8, 0}, {"u8", K_U8, 0}, {"i16", K_I16, 0},
    {"u16", K_U16, 0}, {"i32", K_I32, 0}, {"u32", K_U32, 0}, {"i64", K_I64, 0}, {"u64", K_U64, 0},
    {"bool", K_BOOL, 0}, {"rs", K_RSTR, 0}, {"ps", K_PSTR, 0}};
#define NBASES (sizeof(bases) / sizeof(bases[0]))

/* ---- schemas ----------------------------------------------------------------------- */

static void free_node(node *n) {
    if (!n) return;
    if (n->children) {
        size_t k = (n->kind == K_MSG || n->kind == K_TLIST) ? n->count : 1;
        for (size_t i = 0; i < k; i++) free_node(n->children[i]);
        free(n->children);
    }
    if (n->name) PL_unregister_atom(n->name);
    free(n);
}

static const size_t base_sizes[] = {4, 8, 1, 1, 2, 2, 4, 4, 8, 8, 1, 4, 4};

static node *new_node(enum kind kind) {
    node *n = calloc(1, sizeof(node));
    if (n) {
        n->kind = kind;
        n->min_size = kind <= K_PSTR ? base_sizes[kind] : 0;
    }
    return n;
}

/* The fewest bytes of a compiled node, from its children's. */
static void set_min_size(node *n) {
    size_t size = 0;
    switch (n->kind) {
    case K_MSG:
    case K_TLIST:
        for (size_t i = 0; i < n->count; i++) size += n->children[i]->min_size;
        break;
    case K_ARRAY: size = n->count * n->children[0]->min_size; break;
    case K_SEQ: size = 4; break;
    case K_WRAP: size = n->children[0]->min_size; break;
    case K_CDR: size = 4 + n->children[0]->min_size; break;
    default: return;
    }
    n->min_size = size;
}

static node *compile(term_t t, int depth);

/* The schemas of a proper list, into n->children (n->count of them). */
static int compile_list(term_t list, node *n, int depth) {
    size_t len;
    if (PL_skip_list(list, 0, &len) != PL_LIST) return FALSE;
    n->count = len;
    n->children = calloc(len ? len : 1, sizeof(node *));
    if (!n->children) return FALSE;
    term_t tail = PL_copy_term_ref(list), head = PL_new_term_ref();
    for (size_t i = 0; i < len; i++) {
        if (!PL_get_list(tail, head, tail) || !(n->children[i] = compile(head, depth + 1))) return FALSE;
    }
    return TRUE;
}

static node *compile(term_t t, int depth) {
    atom_t name;
    if (depth == 0 && PL_is_functor(t, PL_new_functor(a_cdr, 1))) {
        node *n = new_node(K_CDR);
        term_t arg = PL_new_term_ref();
        if (!n || !(n->children = calloc(1, sizeof(node *))) || !PL_get_arg(1, t, arg) ||
            !(n->children[0] = compile(arg, 1))) {
            free_node(n);
            return NULL;
        }
        set_min_size(n);
        return n;
    }
    size_t arity;
    node *n = NULL;
    term_t arg = PL_new_term_ref(), arg2 = PL_new_term_ref();
    if (depth > 100) return NULL;
    if (PL_get_atom(t, &name)) {
        for (size_t i = 0; i < NBASES; i++)
            if (bases[i].atom == name) return new_node(bases[i].kind);
        return NULL;
    }
    if (!PL_get_name_arity(t, &name, &arity)) return NULL;
    if (name == a_m && arity == 2) {
        atom_t functor_name;
        if (!(n = new_node(K_MSG)) || !PL_get_arg(1, t, arg) || !PL_get_atom(arg, &functor_name) ||
            !PL_get_arg(2, t, arg2) || !compile_list(arg2, n, depth))
            goto fail;
        n->name = functor_name;
        PL_register_atom(functor_name);
        if (n->count) n->functor = PL_new_functor(functor_name, n->count);
        set_min_size(n);
        return n;
    }
    if (name == a_tl && arity == 1) {
        if (!(n = new_node(K_TLIST)) || !PL_get_arg(1, t, arg) || !compile_list(arg, n, depth)) goto fail;
        set_min_size(n);
        return n;
    }
    if ((name == a_a && arity == 2) || (name == a_q && arity == 1) || (name == a_w && arity == 2)) {
        enum kind kind = name == a_a ? K_ARRAY : name == a_q ? K_SEQ : K_WRAP;
        if (!(n = new_node(kind)) || !(n->children = calloc(1, sizeof(node *)))) goto fail;
        if (kind == K_ARRAY) {
            int64_t count;
            if (!PL_get_arg(1, t, arg) || !PL_get_int64(arg, &count) || count < 0) goto fail;
            n->count = (size_t)count;
        } else if (kind == K_WRAP) {
            atom_t functor_name;
            if (!PL_get_arg(1, t, arg) || !PL_get_atom(arg, &functor_name)) goto fail;
            n->name = functor_name;
            PL_register_atom(functor_name);
            n->functor = PL_new_functor(functor_name, 1);
        }
        if (!PL_get_arg(arity, t, arg2) || !(n->children[0] = compile(arg2, depth + 1))) goto fail;
        set_min_size(n);
        return n;
    }
fail:
    free_node(n);
    return NULL;
}

/*  rtl_ros1_register(+Schema, -Handle): Handle is a small integer naming the schema. */
static foreign_t pl_register(term_t schema, term_t handle) {
    node *n = compile(schema, 0);
    if (!n) return PL_domain_error("ros1_schema", schema);
    pthread_mutex_lock(&schema_lock);
    size_t index = schema_count;
    if (index < MAX_SCHEMAS) schemas[schema_count++] = n;
    pthread_mutex_unlock(&schema_lock);
    if (index >= MAX_SCHEMAS) {
        free_node(n);
        return PL_resource_error("ros1_schemas");
    }
    return PL_unify_int64(handle, (int64_t)index);
}

/* ---- decoding ------------------------------------------------------------------------ */

typedef struct {
    const unsigned char *p, *end;
    const unsigned char *base;  /* CDR: the payload's start (alignment is relative to it); else NULL */
} cursor;

/* CDR: skip the padding before a value aligned to `align` bytes. */
static int align_to(cursor *c, size_t align) {
    if (!c->base || align <= 1) return TRUE;
    size_t pad = (align - (size_t)(c->p - c->base) % align) % align;
    if ((size_t)(c->end - c->p) < pad) return FALSE;
    c->p += pad;
    return TRUE;
}

static int take_bytes(cursor *c, size_t size, const unsigned char **at) {
    if ((size_t)(c->end - c->p) < size) return FALSE;
    *at = c->p;
    c->p += size;
    return TRUE;
}

/* A value of `size` bytes (a number, a count, a string's length), aligned in CDR. */
static int take(cursor *c, size_t size, const unsigned char **at) {
    return align_to(c, size < 8 ? size : 8) && take_bytes(c, size, at);
}

static uint64_t le(const unsigned char *b, int size) {
    uint64_t v = 0;
    for (int i = size - 1; i >= 0; i--) v = (v << 8) | b[i];
    return v;
}

/* Strict UTF-8, as Python's bytes.decode("utf-8"): no overlong forms, no surrogates,
   nothing above U+10FFFF. */
static int valid_utf8(const unsigned char *s, size_t len) {
    size_t i = 0;
    while (i < len) {
        unsigned char c = s[i];
        if (c < 0x80) { i++; continue; }
        size_t need;
        uint32_t cp;
        if (c >= 0xC2 && c <= 0xDF) { need = 1; cp = c & 0x1F; }
        else if (c >= 0xE0 && c <= 0xEF) { need = 2; cp = c & 0x0F; }
        else if (c >= 0xF0 && c <= 0xF4) { need = 3; cp = c & 0x07; }
        else return FALSE;
        if (len - i <= need) return FALSE;
        for (size_t k = 1; k <= need; k++) {
            if ((s[i + k] & 0xC0) != 0x80) return FALSE;
            cp = (cp << 6) | (s[i + k] & 0x3F);
        }
        if ((need == 2 && (cp < 0x800 || (cp >= 0xD800 && cp <= 0xDFFF))) ||
            (need == 3 && (cp < 0x10000 || cp > 0x10FFFF)))
            return FALSE;
        i += need + 1;
    }
    return TRUE;
}

static int decode(const node *n, cursor *c, term_t t);

static int decode_string(const node *n, cursor *c, term_t t) {
    const unsigned char *b, *s;
    if (!take(c, 4, &b)) return FALSE;
    size_t len = (size_t)le(b, 4);
    if (!take_bytes(c, len, &s)) return FALSE;
    if (c->base) {                  /* CDR: the length counts the final NUL */
        if (len == 0 || s[len - 1] != 0) return FALSE;
        len--;
    }
    if (!valid_utf8(s, len)) return FALSE;
    if (n->kind == K_PSTR) return PL_unify_chars(t, PL_ATOM | REP_UTF8, len, (const char *)s);
    char small[256];
    char *buf = len + 2 <= sizeof(small) ? small : malloc(len + 2);
    if (!buf) return FALSE;
    buf[0] = '"';
    memcpy(buf + 1, s, len);
    buf[len + 1] = '"';
    int ok = PL_unify_chars(t, PL_ATOM | REP_UTF8, len + 2, buf);
    if (buf != small) free(buf);
    return ok;
}

/* `count` elements of `element` into the list t. Compound elements are built in a foreign
   frame each, so a long array does not use up term references. */
static int decode_list(const node *element, size_t count, cursor *c, term_t t) {
    term_t tail = PL_copy_term_ref(t), head = PL_new_term_ref();
    int framed = element->kind >= K_MSG;
    for (size_t i = 0; i < count; i++) {
        if (!PL_unify_list(tail, head, tail)) return FALSE;
        if (framed) {
            fid_t frame = PL_open_foreign_frame();
            int ok = decode(element, c, head);
            PL_close_foreign_frame(frame);
            if (!ok) return FALSE;
        } else if (!decode(element, c, head)) {
            return FALSE;
        }
    }
    return PL_unify_nil(tail);
}

static int decode(const node *n, cursor *c, term_t t) {
    const unsigned char *b;
    switch (n->kind) {
    case K_F32: {
        if (!take(c, 4, &b)) return FALSE;
        uint32_t bits = (uint32_t)le(b, 4);
        float f;
        memcpy(&f, &bits, 4);
        return isfinite(f) && PL_unify_float(t, (double)f);
    }
    case K_F64: {
        if (!take(c, 8, &b)) return FALSE;
        uint64_t bits = le(b, 8);
        double d;
        memcpy(&d, &bits, 8);
        return isfinite(d) && PL_unify_float(t, d);
    }
    case K_I8: return take(c, 1, &b) && PL_unify_int64(t, (int8_t)b[0]);
    case K_U8: return take(c, 1, &b) && PL_unify_int64(t, b[0]);
    case K_I16: return take(c, 2, &b) && PL_unify_int64(t, (int16_t)le(b, 2));
    case K_U16: return take(c, 2, &b) && PL_unify_int64(t, (uint16_t)le(b, 2));
    case K_I32: return take(c, 4, &b) && PL_unify_int64(t, (int32_t)le(b, 4));
    case K_U32: return take(c, 4, &b) && PL_unify_int64(t, (uint32_t)le(b, 4));
    case K_I64: return take(c, 8, &b) && PL_unify_int64(t, (int64_t)le(b, 8));
    case K_U64: return take(c, 8, &b) && PL_unify_uint64(t, le(b, 8));
    case K_BOOL: return take(c, 1, &b) && PL_unify_atom(t, b[0] ? a_true : a_false);
    case K_RSTR:
    case K_PSTR: return decode_string(n, c, t);
    case K_MSG: {
        if (!n->count)          /* CDR: an empty message is one byte (rosidl's placeholder) */
            return (!c->base || take(c, 1, &b)) && PL_unify_atom(t, n->name);
        if (!PL_unify_functor(t, n->functor)) return FALSE;
        term_t arg = PL_new_term_ref();
        for (size_t i = 0; i < n->count; i++)
            if (!PL_get_arg(i + 1, t, arg) || !decode(n->children[i], c, arg)) return FALSE;
        return TRUE;
    }
    case K_TLIST: {
        term_t tail = PL_copy_term_ref(t), head = PL_new_term_ref();
        for (size_t i = 0; i < n->count; i++)
            if (!PL_unify_list(tail, head, tail) || !decode(n->children[i], c, head)) return FALSE;
        return PL_unify_nil(tail);
    }
    case K_ARRAY: return decode_list(n->children[0], n->count, c, t);
    case K_SEQ: {
        if (!take(c, 4, &b)) return FALSE;
        size_t count = (size_t)le(b, 4), size = n->children[0]->min_size;
        /* no more elements than the bytes left can hold (empty messages: a bound) */
        if (size ? count > (size_t)(c->end - c->p) / size : count > 65536) return FALSE;
        return decode_list(n->children[0], count, c, t);
    }
    case K_WRAP: {
        term_t arg = PL_new_term_ref();
        return PL_unify_functor(t, n->functor) && PL_get_arg(1, t, arg) && decode(n->children[0], c, arg);
    }
    case K_CDR: {               /* little-endian CDR (0x0001); the options are not read */
        if (!take_bytes(c, 4, &b) || b[0] != 0 || b[1] != 1) return FALSE;
        c->base = c->p;
        if (!decode(n->children[0], c, t) || (size_t)(c->end - c->p) > 3) return FALSE;
        while (c->p < c->end)   /* padding only */
            if (*c->p++ != 0) return FALSE;
        return TRUE;
    }
    }
    return FALSE;
}

/*  rtl_ros1_term(+Handle, +Bytes, -Term) is semidet. */
static foreign_t pl_term(term_t handle, term_t bytes, term_t term) {
    int64_t index;
    size_t len;
    char *data;
    if (!PL_get_int64_ex(handle, &index)) return FALSE;
    pthread_mutex_lock(&schema_lock);
    const node *n = index >= 0 && (size_t)index < schema_count ? schemas[index] : NULL;
    pthread_mutex_unlock(&schema_lock);
    if (!n) return PL_existence_error("ros1_schema", handle);
    /* a copy: building the term may move the stacks the string lives on */
    if (!PL_get_nchars(bytes, &len, &data, CVT_STRING | REP_ISO_LATIN_1 | BUF_MALLOC | CVT_EXCEPTION))
        return FALSE;
    cursor c = {(const unsigned char *)data, (const unsigned char *)data + len, NULL};
    term_t out = PL_new_term_ref();
    int ok = decode(n, &c, out) && c.p == c.end;
    PL_free(data);
    return ok && PL_unify(term, out);
}

install_t install_rtl_ros1(void) {
    a_true = PL_new_atom("true");
    a_false = PL_new_atom("false");
    a_m = PL_new_atom("m");
    a_tl = PL_new_atom("tl");
    a_a = PL_new_atom("a");
    a_q = PL_new_atom("q");
    a_w = PL_new_atom("w");
    a_cdr = PL_new_atom("cdr");
    for (size_t i = 0; i < NBASES; i++) bases[i].atom = PL_new_atom(bases[i].name);
    PL_register_foreign("rtl_ros1_register", 2, pl_register, 0);
    PL_register_foreign("rtl_ros1_term", 3, pl_term, 0);
}
