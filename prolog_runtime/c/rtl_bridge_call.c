/*  rtl_bridge_call: one C call for one request of the Python bridge (retalisc/driver/bridge.py).

    The pyswip road of the bridge builds the arguments of retalisc_bridge:bridge_apply/6
    (prolog_runtime/rtl_bridge.pl) with one ctypes call per value and reads the answer with
    a few more: about twenty crossings of ctypes, each costing more than the Prolog work of a
    short request. This library does the whole request in one call from Python:

        int rtl_bridge_apply(const char *module, const char *name,
                             const char *args, size_t args_len,
                             const char **out, size_t *out_len,
                             const char **err, size_t *err_len)

    args is the argument list as data, never as text to read: a sequence of tagged values,
        's' u32 n, n bytes        a string (UTF-8)
        'b' u32 n, n bytes        a string of codes 0..255 (the bytes themselves)
        'i' i64                   an integer
        'f' f64                   a float
        'l' u32 n, n values       a list
    little-endian, as Python's struct module packs '<'. The return value is bridge_apply/6's
    Status (1 success, 0 failure, 2 error), or -1 when the call itself raised (the exception's
    writeq text in err) or -2 when args is malformed. out is the UTF-8 text of Out (success)
    or the message (error), err the writeq text of the error term; both stay valid until the
    next call from the same thread.

    When the calling thread owns the runtime's state (rtl_bridge_claimed, after
    retalisc_bridge:claim_caller/1 said so), rtl_bridge_call runs the API predicate itself,
    resolved once (rtl_bridge_predicate), with the values put straight into its arguments:
    no goal built from names, no handoff, no catch/3 frame in Prolog; an exception is turned
    into Status 2 by retalisc_bridge:bridge_error/4 (the same printer), an answer that is not
    an atom or a string into text by retalisc_bridge:text_of/2. rtl_bridge_call_numbers
    reads an answer `F(R1, ..., Rm, I1, ..., Ik)` into m doubles and k integers (Status 1)
    without text; any other answer is returned as text with Status 3. On any other thread
    both do what rtl_bridge_apply does.

    Not a Prolog foreign library: Python loads it with ctypes, in a process that has loaded
    libswipl. The calling thread must have a Prolog engine (PL_thread_attach_engine).
*/

#include <SWI-Prolog.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct
{ char  *data;
  size_t size;
} buffer;

static __thread buffer out_buffer;
static __thread buffer err_buffer;

static int
keep(buffer *b, const char *s, size_t len, const char **text, size_t *text_len)
{ if ( len + 1 > b->size )
  { size_t size = len + 1 > 256 ? len + 1 : 256;
    char *data = realloc(b->data, size);
    if ( !data )
      return FALSE;
    b->data = data;
    b->size = size;
  }
  memcpy(b->data, s, len);
  b->data[len] = 0;
  *text = b->data;
  *text_len = len;
  return TRUE;
}

static int
keep_term(buffer *b, term_t t, unsigned int flags, const char **text, size_t *text_len)
{ size_t len;
  char *s;

  if ( !PL_get_nchars(t, &len, &s, flags|REP_UTF8|BUF_STACK) )
    return FALSE;
  return keep(b, s, len, text, text_len);
}

typedef struct
{ const unsigned char *at;
  const unsigned char *end;
} reader;

static int
read_u32(reader *r, uint32_t *v)
{ if ( r->end - r->at < 4 )
    return FALSE;
  *v = (uint32_t)r->at[0] | (uint32_t)r->at[1] << 8 | (uint32_t)r->at[2] << 16 |
       (uint32_t)r->at[3] << 24;
  r->at += 4;
  return TRUE;
}

static int
read_u64(reader *r, uint64_t *v)
{ uint64_t x = 0;

  if ( r->end - r->at < 8 )
    return FALSE;
  for (int i = 7; i >= 0; i--)
    x = x << 8 | r->at[i];
  r->at += 8;
  *v = x;
  return TRUE;
}

/* Put the next value of r into t; FALSE when r is malformed or Prolog cannot make it. */
static int
put_value(reader *r, term_t t, int depth)
{ uint32_t n;
  uint64_t u;

  if ( r->at >= r->end || depth > 100 )
    return FALSE;
  switch ( *r->at++ )
  { case 's':
      if ( !read_u32(r, &n) || (size_t)(r->end - r->at) < n )
        return FALSE;
      r->at += n;
      return PL_put_chars(t, PL_STRING|REP_UTF8, n, (const char *)r->at - n);
    case 'b':
      if ( !read_u32(r, &n) || (size_t)(r->end - r->at) < n )
        return FALSE;
      r->at += n;
      return PL_put_chars(t, PL_STRING|REP_ISO_LATIN_1, n, (const char *)r->at - n);
    case 'i':
      if ( !read_u64(r, &u) )
        return FALSE;
      return PL_put_int64(t, (int64_t)u);
    case 'f':
    { double d;
      if ( !read_u64(r, &u) )
        return FALSE;
      memcpy(&d, &u, sizeof d);
      return PL_put_float(t, d);
    }
    case 'l':
    { term_t items, tail;
      if ( !read_u32(r, &n) || !(items = PL_new_term_refs(n ? n : 1)) )
        return FALSE;
      for (uint32_t i = 0; i < n; i++)
        if ( !put_value(r, items + i, depth + 1) )
          return FALSE;
      if ( !(tail = PL_new_term_ref()) || !PL_put_nil(tail) )
        return FALSE;
      for (uint32_t i = n; i-- > 0; )
        if ( !PL_cons_list(tail, items + i, tail) )
          return FALSE;
      return PL_put_term(t, tail);
    }
    default:
      return FALSE;
  }
}

static predicate_t apply_predicate;

int
rtl_bridge_apply(const char *module, const char *name, const char *args, size_t args_len,
                 const char **out, size_t *out_len, const char **err, size_t *err_len)
{ fid_t fid;
  term_t t;
  reader r = { (const unsigned char *)args, (const unsigned char *)args + args_len };
  int status = -2;

  *out = *err = "";
  *out_len = *err_len = 0;
  if ( !apply_predicate )
    apply_predicate = PL_predicate("bridge_apply", 6, "retalisc_bridge");
  if ( !(fid = PL_open_foreign_frame()) )
    return -1;
  PL_STRINGS_MARK();
  if ( (t = PL_new_term_refs(6)) &&
       PL_put_chars(t, PL_STRING|REP_UTF8, (size_t)-1, module) &&
       PL_put_chars(t + 1, PL_STRING|REP_UTF8, (size_t)-1, name) &&
       put_value(&r, t + 2, 0) && r.at == r.end )
  { if ( PL_call_predicate(NULL, PL_Q_NODEBUG|PL_Q_PASS_EXCEPTION, apply_predicate, t) )
    { int s;
      if ( PL_get_integer(t + 3, &s) )
      { status = s;
        if ( (s == 1 || s == 2) && !keep_term(&out_buffer, t + 4, CVT_ATOM|CVT_STRING|CVT_LIST, out, out_len) )
          status = -1;
        if ( s == 2 && !keep_term(&err_buffer, t + 5, CVT_ATOM|CVT_STRING, err, err_len) )
          status = -1;
      } else
        status = -1;
    } else
      status = -1;
  }
  if ( status < 0 )
  { term_t ex = PL_exception(0);
    if ( ex )
    { keep_term(&err_buffer, ex, CVT_WRITEQ, err, err_len);
      PL_clear_exception();
    }
  }
  PL_STRINGS_RELEASE();
  PL_discard_foreign_frame(fid);
  return status;
}

/* The calling thread owns the state: the runtime's requests run in it (claim_caller/1). */
static int owner_thread = -1;

void
rtl_bridge_claimed(void)
{ owner_thread = PL_thread_self();
}

void *
rtl_bridge_predicate(const char *module, const char *name, int arity)
{ return (void *)PL_predicate(name, arity, module);
}

static predicate_t text_of_predicate, error_predicate;

/* Status 2 (or -1) for the exception pending after a call, by bridge_error/4. */
static int
call_error(const char **out, size_t *out_len, const char **err, size_t *err_len)
{ term_t ex = PL_exception(0), t;
  int status = -1;

  if ( !ex || !(t = PL_new_term_refs(4)) || !PL_put_term(t, ex) )
    return -1;
  PL_clear_exception();
  if ( !error_predicate )
    error_predicate = PL_predicate("bridge_error", 4, "retalisc_bridge");
  if ( PL_call_predicate(NULL, PL_Q_NODEBUG|PL_Q_PASS_EXCEPTION, error_predicate, t) &&
       keep_term(&out_buffer, t + 2, CVT_ATOM|CVT_STRING, out, out_len) &&
       keep_term(&err_buffer, t + 3, CVT_ATOM|CVT_STRING, err, err_len) )
    status = 2;
  else if ( (ex = PL_exception(0)) )
  { keep_term(&err_buffer, ex, CVT_WRITEQ, err, err_len);
    PL_clear_exception();
  }
  return status;
}

/* The text of the answer in t, as bridge_apply/6's text_of/2 makes it. */
static int
answer_text(term_t t, const char **out, size_t *out_len, const char **err, size_t *err_len)
{ term_t a;

  if ( keep_term(&out_buffer, t, CVT_ATOM|CVT_STRING, out, out_len) )
    return 1;
  if ( !text_of_predicate )
    text_of_predicate = PL_predicate("text_of", 2, "retalisc_bridge");
  if ( !(a = PL_new_term_refs(2)) || !PL_put_term(a, t) )
    return -1;
  if ( !PL_call_predicate(NULL, PL_Q_NODEBUG|PL_Q_PASS_EXCEPTION, text_of_predicate, a) )
    return call_error(out, out_len, err, err_len);
  return keep_term(&out_buffer, a + 1, CVT_ATOM|CVT_STRING, out, out_len) ? 1 : -1;
}

/* Run pred with the values of args (a list of n values) and one more argument, the answer,
   in the calling thread: Status as rtl_bridge_apply's; *answer the answer's term. */
static int
call_direct(predicate_t pred, reader *r, term_t *answer,
            const char **out, size_t *out_len, const char **err, size_t *err_len)
{ uint32_t n;
  term_t t;
  size_t arity;

  if ( r->at >= r->end || *r->at++ != 'l' || !read_u32(r, &n) )
    return -2;
  if ( !PL_predicate_info(pred, NULL, &arity, NULL) )
    return -1;
  if ( arity != (size_t)n + 1 )
    return -2;
  if ( !(t = PL_new_term_refs(n + 1)) )
    return -1;
  for (uint32_t i = 0; i < n; i++)
    if ( !put_value(r, t + i, 0) )
      return -2;
  if ( r->at != r->end )
    return -2;
  if ( !PL_call_predicate(NULL, PL_Q_NODEBUG|PL_Q_PASS_EXCEPTION, pred, t) )
    return PL_exception(0) ? call_error(out, out_len, err, err_len) : 0;
  *answer = t + n;
  return 1;
}

int
rtl_bridge_call(void *pred, const char *module, const char *name, const char *args, size_t args_len,
                const char **out, size_t *out_len, const char **err, size_t *err_len)
{ fid_t fid;
  term_t answer;
  reader r = { (const unsigned char *)args, (const unsigned char *)args + args_len };
  int status;

  if ( !pred || owner_thread < 0 || PL_thread_self() != owner_thread )
    return rtl_bridge_apply(module, name, args, args_len, out, out_len, err, err_len);
  *out = *err = "";
  *out_len = *err_len = 0;
  if ( !(fid = PL_open_foreign_frame()) )
    return -1;
  PL_STRINGS_MARK();
  status = call_direct((predicate_t)pred, &r, &answer, out, out_len, err, err_len);
  if ( status == 1 )
    status = answer_text(answer, out, out_len, err, err_len);
  PL_STRINGS_RELEASE();
  PL_discard_foreign_frame(fid);
  return status;
}

int
rtl_bridge_call_numbers(void *pred, const char *module, const char *name, const char *args, size_t args_len,
                        double *reals, int nreals, int64_t *ints, int nints,
                        const char **out, size_t *out_len, const char **err, size_t *err_len)
{ fid_t fid;
  term_t answer, arg;
  reader r = { (const unsigned char *)args, (const unsigned char *)args + args_len };
  int status;
  size_t arity;

  if ( !pred || owner_thread < 0 || PL_thread_self() != owner_thread )
  { status = rtl_bridge_apply(module, name, args, args_len, out, out_len, err, err_len);
    return status == 1 ? 3 : status;
  }
  *out = *err = "";
  *out_len = *err_len = 0;
  if ( !(fid = PL_open_foreign_frame()) )
    return -1;
  PL_STRINGS_MARK();
  status = call_direct((predicate_t)pred, &r, &answer, out, out_len, err, err_len);
  if ( status == 1 )
  { if ( PL_get_compound_name_arity_sz(answer, NULL, &arity) && arity == (size_t)(nreals + nints) &&
         (arg = PL_new_term_ref()) )
    { for (int i = 0; i < nreals && status == 1; i++)
        if ( !PL_get_arg(i + 1, answer, arg) || !PL_get_float(arg, &reals[i]) )
          status = -3;
      for (int i = 0; i < nints && status == 1; i++)
        if ( !PL_get_arg(nreals + i + 1, answer, arg) || !PL_get_int64(arg, &ints[i]) )
          status = -3;
      if ( status == -3 )
        status = answer_text(answer, out, out_len, err, err_len) == 1 ? 3 : -1;
    } else
      status = answer_text(answer, out, out_len, err, err_len) == 1 ? 3 : -1;
  }
  PL_STRINGS_RELEASE();
  PL_discard_foreign_frame(fid);
  return status;
}
