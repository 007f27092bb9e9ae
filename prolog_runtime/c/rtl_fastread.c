/*  rtl_fastread: the common case of an event line, read in C.

    rtl_fast_event_line(+Line, +MaxDepth, +MaxDigits, -Event, -T, -Start, -End, -Op)
    succeeds for a line such as

        {"event": "pose(r1, [1.5, -2], 'Frame A')", "t": 12.5}

    and fails for everything else, which rtl_io.pl then reads with the Prolog reader (the
    reference: this reader only takes lines whose meaning is beyond doubt, and returns
    what the Prolog path would). Taken:

      - one JSON object with string keys free of escapes, surrounded by JSON layout;
        the keys "event", "t", "start", "end" and "op" at most once each; other keys
        with a string, number, true, false, null or an array of numbers as value
      - "event": a string without escapes holding a ground term made of lowercase
        identifiers, quoted atoms without escapes, integers that fit 64 bits,
        floats written digits.digits[e[+-]digits], a minus sign stuck to a number,
        compound terms name(Args) and proper lists [A, B]; spaces between tokens;
        a final full stop; nested at most MaxDepth (and 200) levels
      - "t", "start", "end": a JSON number or an array of two JSON integers (the
        caller checks the time values themselves)
      - "op": "add" or "retract" (unbound Op when absent)

    Only ASCII: a byte outside 0x20..0x7e anywhere in the line fails, and so does a run of
    more than MaxDigits digits (-1: no limit) anywhere in it (rtl_io.pl rejects it).

    rtl_fast_event_json(+Event, +Start, +End, -Json) is the common output line, written
    as rtl_io:rtl_event_json/6 writes it for no consumer and Op `add`:

        {"event": "p(1,'A b')", "start": 12, "end": 12.5}

    the term written as writeq/1 writes it (UTF-8; a plain term, such as the one above, by
    this file itself, any other by PL_write_term()), escaped as the inside of a JSON string
    the way rtl_json_string_escape/2 escapes; it fails when Start or End is not a finite
    number (rtl_io.pl writes those). rtl_fast_write_event(+Stream, +Event, +Start, +End)
    writes that line and a newline to a UTF-8 stream.

    rtl_fast_output_data(+Records, -Json) writes buffered output records as the two JSON
    arrays rtl_io:rtl_output_data/2 writes (the form in which outputs cross to Python), byte
    for byte: the outputs (`[Text, Start, End]` for event(E, S, T, -, add), the object of its
    line for any other event, a json(Line) record's line as it is), a newline, and the terms
    as data (numbers, atoms as JSON strings, ["c", Name, Arg...], ["l", Item...], ["s", Text],
    ["f", "inf"]; null for a json(Line) record). It fails,
    writing nothing, for what it leaves to the Prolog writer: times that are not finite or
    integers beyond 64 bits, variables, terms nested deeper than 200 levels, dicts and blobs.
*/

#include <SWI-Stream.h>
#include <SWI-Prolog.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <math.h>

#define MAX_ARITY 256
#define MAX_NESTING 200

typedef struct {
    const char *p;              /* next character */
    const char *end;            /* end of the text being read */
    int max_depth;
} reader;

static int is_json_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
static int is_lower(char c) { return c >= 'a' && c <= 'z'; }
static int is_digit(char c) { return c >= '0' && c <= '9'; }
static int is_alnum(char c)
{ return is_lower(c) || is_digit(c) || (c >= 'A' && c <= 'Z') || c == '_'; }

static void skip_json_space(reader *r)
{ while ( r->p < r->end && is_json_space(*r->p) ) r->p++; }

static void skip_spaces(reader *r)
{ while ( r->p < r->end && *r->p == ' ' ) r->p++; }

static int peek(reader *r) { return r->p < r->end ? (unsigned char)*r->p : -1; }

/* ---- Prolog terms ------------------------------------------------------------------ */

static int read_term(reader *r, int depth, term_t t);

/* The number written in [start, end) (already checked), into t (0: only check that it can
   be represented: a finite double, an integer of at most 18 digits). */
static int put_number_text(const char *start, const char *end, int is_float, term_t t)
{ char buf[64];
  size_t len = (size_t)(end - start);
  if ( len >= sizeof(buf) ) return FALSE;
  memcpy(buf, start, len);
  buf[len] = '\0';
  errno = 0;
  if ( is_float )
  { double d = strtod(buf, NULL);
    if ( errno != 0 || !isfinite(d) ) return FALSE;
    return t ? PL_put_float(t, d) : TRUE;
  }
  if ( len > 18 ) return FALSE;             /* may not fit: leave it to the reader */
  long long i = strtoll(buf, NULL, 10);
  if ( errno != 0 ) return FALSE;
  return t ? PL_put_int64(t, (int64_t)i) : TRUE;
}

/* digits[.digits[e[+-]digits]] with an optional minus sign stuck to it */
static int read_number(reader *r, term_t t)
{ const char *start = r->p;
  int is_float = 0;

  if ( *r->p == '-' ) r->p++;
  if ( r->p >= r->end || !is_digit(*r->p) ) return FALSE;
  while ( r->p < r->end && is_digit(*r->p) ) r->p++;
  if ( r->p + 1 < r->end && r->p[0] == '.' && is_digit(r->p[1]) )
  { is_float = 1;
    r->p++;
    while ( r->p < r->end && is_digit(*r->p) ) r->p++;
    if ( r->p < r->end && (*r->p == 'e' || *r->p == 'E') )
    { r->p++;
      if ( r->p < r->end && (*r->p == '+' || *r->p == '-') ) r->p++;
      if ( r->p >= r->end || !is_digit(*r->p) ) return FALSE;
      while ( r->p < r->end && is_digit(*r->p) ) r->p++;
    }
  }
  /* 0'c, 0x1F, 1_000, 1e10, 1.0Inf: the Prolog reader decides */
  if ( r->p < r->end && (is_alnum(*r->p) || *r->p == '\'') ) return FALSE;
  return put_number_text(start, r->p, is_float, t);
}

/* A name: a lowercase identifier or a quoted atom without escapes. */
static int read_name(reader *r, const char **name, size_t *len)
{ if ( is_lower(*r->p) )
  { *name = r->p;
    while ( r->p < r->end && is_alnum(*r->p) ) r->p++;
    *len = (size_t)(r->p - *name);
    return TRUE;
  }
  if ( *r->p == '\'' )
  { const char *q = ++r->p;
    while ( r->p < r->end && *r->p != '\'' )
    { if ( *r->p == '\\' ) return FALSE;
      r->p++;
    }
    if ( r->p >= r->end ) return FALSE;
    *name = q;
    *len = (size_t)(r->p - q);
    r->p++;
    if ( r->p < r->end && *r->p == '\'' ) return FALSE;   /* '' inside a quoted atom */
    return TRUE;
  }
  return FALSE;
}

static int read_arguments(reader *r, int depth, atom_t name, term_t t)
{ term_t args[MAX_ARITY];
  int arity = 0;

  r->p++;                                       /* ( */
  for (;;)
  { if ( arity == MAX_ARITY ) return FALSE;
    args[arity] = PL_new_term_ref();
    if ( !read_term(r, depth + 1, args[arity]) ) return FALSE;
    arity++;
    skip_spaces(r);
    if ( peek(r) == ',' ) { r->p++; continue; }
    if ( peek(r) == ')' ) { r->p++; break; }
    return FALSE;
  }
  term_t av = PL_new_term_refs(arity);
  for (int i = 0; i < arity; i++)
  { if ( !PL_put_term(av + i, args[i]) ) return FALSE;
  }
  functor_t f = PL_new_functor(name, (size_t)arity);
  return PL_cons_functor_v(t, f, av);
}

static int read_list(reader *r, int depth, term_t t)
{ r->p++;                                       /* [ */
  skip_spaces(r);
  if ( peek(r) == ']' ) { r->p++; return PL_put_nil(t); }

  term_t tail = PL_copy_term_ref(t);
  term_t head = PL_new_term_ref();
  term_t elem = PL_new_term_ref();
  PL_put_variable(t);
  if ( !PL_put_term(tail, t) ) return FALSE;
  for (;;)
  { if ( !read_term(r, depth + 1, elem) ) return FALSE;
    if ( !PL_unify_list(tail, head, tail) || !PL_unify(head, elem) ) return FALSE;
    skip_spaces(r);
    if ( peek(r) == ',' ) { r->p++; continue; }
    if ( peek(r) == ']' ) { r->p++; break; }
    return FALSE;                               /* '|' tails and the rest: the reader */
  }
  return PL_unify_nil(tail);
}

static int read_term(reader *r, int depth, term_t t)
{ if ( depth > r->max_depth || depth > MAX_NESTING ) return FALSE;
  skip_spaces(r);
  int c = peek(r);
  if ( c < 0 ) return FALSE;
  if ( is_digit((char)c) ) return read_number(r, t);
  if ( c == '-' ) return read_number(r, t);
  if ( c == '[' )
  { if ( r->p + 1 < r->end && r->p[1] == ']' )      /* [] */
    { r->p += 2;
      return depth > 0 && PL_put_nil(t);            /* a bare [] is no event */
    }
    return depth > 0 && read_list(r, depth, t);
  }
  const char *name;
  size_t len;
  if ( !read_name(r, &name, &len) ) return FALSE;
  atom_t a = PL_new_atom_nchars(len, name);
  int ok;
  if ( peek(r) == '(' )
    ok = read_arguments(r, depth, a, t);
  else
    ok = PL_put_atom(t, a);
  PL_unregister_atom(a);
  return ok;
}

/* The whole event text: one term, then optionally a full stop, then spaces. */
static int read_event_text(const char *s, const char *e, int max_depth, term_t t)
{ reader r = { s, e, max_depth };
  if ( !read_term(&r, 0, t) ) return FALSE;
  if ( !PL_is_atom(t) && !PL_is_compound(t) ) return FALSE;
  skip_spaces(&r);
  if ( peek(&r) == '.' ) { r.p++; skip_spaces(&r); }
  return r.p == r.end;
}

/* ---- JSON -------------------------------------------------------------------------- */

/* A string without escapes: [*s, *e) is its content. */
static int json_plain_string(reader *r, const char **s, const char **e)
{ if ( peek(r) != '"' ) return FALSE;
  const char *q = ++r->p;
  while ( r->p < r->end && *r->p != '"' )
  { if ( *r->p == '\\' || (unsigned char)*r->p < 0x20 ) return FALSE;
    r->p++;
  }
  if ( r->p >= r->end ) return FALSE;
  *s = q;
  *e = r->p++;
  return TRUE;
}

/* -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)? */
static int json_number(reader *r, term_t t, int integer_only)
{ const char *start = r->p;
  int is_float = 0;
  if ( peek(r) == '-' ) r->p++;
  if ( peek(r) == '0' ) r->p++;
  else if ( peek(r) >= '1' && peek(r) <= '9' )
  { while ( r->p < r->end && is_digit(*r->p) ) r->p++;
  } else return FALSE;
  if ( peek(r) == '.' )
  { is_float = 1;
    r->p++;
    if ( r->p >= r->end || !is_digit(*r->p) ) return FALSE;
    while ( r->p < r->end && is_digit(*r->p) ) r->p++;
  }
  if ( peek(r) == 'e' || peek(r) == 'E' )
  { is_float = 1;
    r->p++;
    if ( peek(r) == '+' || peek(r) == '-' ) r->p++;
    if ( r->p >= r->end || !is_digit(*r->p) ) return FALSE;
    while ( r->p < r->end && is_digit(*r->p) ) r->p++;
  }
  if ( is_float && integer_only ) return FALSE;
  return put_number_text(start, r->p, is_float, t);
}

/* A time: a number or [Integer, Integer]. */
static int json_time(reader *r, term_t t)
{ if ( peek(r) != '[' ) return json_number(r, t, 0);
  r->p++;
  term_t secs = PL_new_term_ref(), nsecs = PL_new_term_ref();
  skip_json_space(r);
  if ( !json_number(r, secs, 1) ) return FALSE;
  skip_json_space(r);
  if ( peek(r) != ',' ) return FALSE;
  r->p++;
  skip_json_space(r);
  if ( !json_number(r, nsecs, 1) ) return FALSE;
  skip_json_space(r);
  if ( peek(r) != ']' ) return FALSE;
  r->p++;
  PL_put_nil(t);
  return PL_cons_list(t, nsecs, t) && PL_cons_list(t, secs, t);
}

static int json_literal(reader *r, const char *word)
{ size_t n = strlen(word);
  if ( (size_t)(r->end - r->p) < n || strncmp(r->p, word, n) != 0 ) return FALSE;
  r->p += n;
  return TRUE;
}

/* The value of a key this reader does not use. */
static int json_skip_value(reader *r)
{ const char *s, *e;
  switch ( peek(r) )
  { case '"': return json_plain_string(r, &s, &e);
    case 't': return json_literal(r, "true");
    case 'f': return json_literal(r, "false");
    case 'n': return json_literal(r, "null");
    case '[':
      r->p++;
      skip_json_space(r);
      if ( peek(r) == ']' ) { r->p++; return TRUE; }
      for (;;)
      { if ( !json_number(r, 0, 0) ) return FALSE;
        skip_json_space(r);
        if ( peek(r) == ',' ) { r->p++; skip_json_space(r); continue; }
        if ( peek(r) == ']' ) { r->p++; return TRUE; }
        return FALSE;
      }
    default: return json_number(r, 0, 0);
  }
}

enum { K_EVENT, K_T, K_START, K_END, K_OP, K_OTHER };

static int key_index(const char *s, const char *e)
{ size_t n = (size_t)(e - s);
  if ( n == 5 && memcmp(s, "event", 5) == 0 ) return K_EVENT;
  if ( n == 1 && s[0] == 't' ) return K_T;
  if ( n == 5 && memcmp(s, "start", 5) == 0 ) return K_START;
  if ( n == 3 && memcmp(s, "end", 3) == 0 ) return K_END;
  if ( n == 2 && memcmp(s, "op", 2) == 0 ) return K_OP;
  return K_OTHER;
}

/* The fields of an event line read in C: Event, the times as given (T, Start, End: fresh
   term references, set when the key was there) and Op (0 when absent). */
typedef struct {
  term_t event;
  term_t times[3];
  int seen[5];
  atom_t op;
} event_line;

static atom_t atom_add, atom_retract;

/* The common case of one event line [text, text+len) into *out; FALSE for the others. */
static int read_event_line(const char *text, size_t len, int depth_limit, long max_digits,
                           event_line *out)
{ long digits = 0;
  for (size_t i = 0; i < len; i++)
  { unsigned char c = (unsigned char)text[i];
    if ( (c < 0x20 && !is_json_space((char)c)) || c > 0x7e ) return FALSE;
    digits = is_digit((char)c) ? digits + 1 : 0;
    if ( max_digits >= 0 && digits > max_digits ) return FALSE;   /* rejected by rtl_io.pl */
  }

  reader r = { text, text + len, depth_limit };
  const char *event_s = NULL, *event_e = NULL;
  term_t *times = out->times;
  int *seen = out->seen;
  atom_t op = 0;
  for (int i = 0; i < 3; i++) times[i] = PL_new_term_ref();
  for (int i = 0; i < 5; i++) seen[i] = 0;

  skip_json_space(&r);
  if ( peek(&r) != '{' ) return FALSE;
  r.p++;
  skip_json_space(&r);
  for (;;)
  { const char *ks, *ke;
    if ( !json_plain_string(&r, &ks, &ke) ) return FALSE;
    skip_json_space(&r);
    if ( peek(&r) != ':' ) return FALSE;
    r.p++;
    skip_json_space(&r);
    int k = key_index(ks, ke);
    if ( k != K_OTHER )
    { if ( seen[k] ) return FALSE;                  /* duplicate keys: the reader */
      seen[k] = 1;
    }
    switch ( k )
    { case K_EVENT:
        if ( !json_plain_string(&r, &event_s, &event_e) ) return FALSE;
        break;
      case K_T: case K_START: case K_END:
        if ( !json_time(&r, times[k - K_T]) ) return FALSE;
        break;
      case K_OP:
      { const char *os, *oe;
        if ( !json_plain_string(&r, &os, &oe) ) return FALSE;
        if ( oe - os == 3 && memcmp(os, "add", 3) == 0 ) op = atom_add;
        else if ( oe - os == 7 && memcmp(os, "retract", 7) == 0 ) op = atom_retract;
        else return FALSE;
        break;
      }
      default:
        if ( !json_skip_value(&r) ) return FALSE;
    }
    skip_json_space(&r);
    if ( peek(&r) == ',' ) { r.p++; skip_json_space(&r); continue; }
    if ( peek(&r) == '}' ) { r.p++; break; }
    return FALSE;
  }
  skip_json_space(&r);
  if ( r.p != r.end || !event_s ) return FALSE;

  out->event = PL_new_term_ref();
  out->op = op;
  return read_event_text(event_s, event_e, depth_limit, out->event);
}

static foreign_t
pl_fast_event_line(term_t line, term_t max_depth, term_t max_digits, term_t event, term_t t_out,
                   term_t start_out, term_t end_out, term_t op_out)
{ char *text;
  size_t len;
  int depth_limit;
  long digit_limit;
  event_line l;

  if ( !PL_get_nchars(line, &len, &text, CVT_STRING|CVT_ATOM) ) return FALSE;
  if ( !PL_get_integer(max_depth, &depth_limit) || !PL_get_long(max_digits, &digit_limit) )
    return FALSE;
  if ( !read_event_line(text, len, depth_limit, digit_limit, &l) ) return FALSE;
  if ( !PL_unify(event, l.event) ) return FALSE;
  if ( l.seen[K_T] && !PL_unify(t_out, l.times[0]) ) return FALSE;
  if ( l.seen[K_START] && !PL_unify(start_out, l.times[1]) ) return FALSE;
  if ( l.seen[K_END] && !PL_unify(end_out, l.times[2]) ) return FALSE;
  if ( l.op && !PL_unify_atom(op_out, l.op) ) return FALSE;
  return TRUE;
}

/* ---- a block of lines ---------------------------------------------------------------- */

/* rtl_fast_read_lines(+Stream, +MaxLines, +MaxDepth, +MaxDigits, +MaxBytes, -Items): the
   complete lines already in the input buffer of Stream (a UTF-8 text stream), at most
   MaxLines, taken from the stream without waiting for more input (MaxDigits: the longest
   run of digits, MaxBytes: the longest line, -1 for no limit): Items is a list of

     a(Event, T)    an event line of the common case (above) with "t" a number, no "start",
                    "end", and "op" absent or "add": what rtl_parse_event_line/3 reads as
                    event(add, Event, T, T) once the time is checked
     l(Line)        any other line, as read_line_to_string/2 would give it

   Items is [] when the buffer holds no complete line. Only lines of bytes 0x01..0x7f are
   taken (they read the same in every encoding this accepts); the block ends before any
   other line and before a line longer than MaxBytes, which the caller then reads (and
   rejects) with rtl_read_line/3. The line is cut as
   read_line_to_string/2 cuts it: at the newline, without '\r's at either end. */
static foreign_t
pl_fast_read_lines(term_t stream, term_t max_lines, term_t max_depth, term_t max_digits,
                   term_t max_bytes, term_t items)
{ IOSTREAM *s;
  int limit, depth_limit;
  long digit_limit, byte_limit;
  int ok = TRUE;

  if ( !PL_get_integer_ex(max_lines, &limit) || !PL_get_integer_ex(max_depth, &depth_limit) ||
       !PL_get_long_ex(max_digits, &digit_limit) || !PL_get_long_ex(max_bytes, &byte_limit) )
    return FALSE;
  if ( !PL_get_stream(stream, &s, SIO_INPUT) ) return FALSE;
  term_t tail = PL_copy_term_ref(items);
  term_t head = PL_new_term_ref();
  functor_t f_a = PL_new_functor(PL_new_atom("a"), 2);
  functor_t f_l = PL_new_functor(PL_new_atom("l"), 1);

  if ( s->encoding == ENC_UTF8 || s->encoding == ENC_ANSI || s->encoding == ENC_ISO_LATIN_1 ||
       s->encoding == ENC_ASCII )
  { for (int n = 0; n < limit && s->bufp < s->limitp; n++)
    { char *start = s->bufp;
      char *nl = memchr(start, '\n', (size_t)(s->limitp - start));
      if ( !nl ) break;
      if ( byte_limit >= 0 && nl - start > byte_limit ) break;
      int plain = TRUE;
      for (char *p = start; p < nl; p++)
      { unsigned char c = (unsigned char)*p;
        if ( c == 0 || c > 0x7f ) { plain = FALSE; break; }
      }
      if ( !plain ) break;
      s->bufp = nl + 1;
      const char *b = start, *e = nl;
      while ( b < e && *b == '\r' ) b++;
      while ( e > b && e[-1] == '\r' ) e--;

      fid_t fid = PL_open_foreign_frame();
      event_line l;
      term_t item = PL_new_term_ref();
      if ( read_event_line(b, (size_t)(e - b), depth_limit, digit_limit, &l) &&
           l.seen[K_T] && !l.seen[K_START] && !l.seen[K_END] && l.op != atom_retract &&
           PL_is_number(l.times[0]) )
        ok = PL_cons_functor(item, f_a, l.event, l.times[0]);
      else
      { term_t text = PL_new_term_ref();
        ok = PL_put_chars(text, PL_STRING, (size_t)(e - b), b) &&
             PL_cons_functor(item, f_l, text);
      }
      ok = ok && PL_unify_list(tail, head, tail) && PL_unify(head, item);
      PL_close_foreign_frame(fid);
      if ( !ok ) break;
    }
  }
  ok = ok && PL_unify_nil(tail);
  return PL_release_stream(s) && ok;
}

/* ---- output lines ------------------------------------------------------------------ */

/* A line is built in a buffer on the C stack of the call (most lines fit: no malloc() per
   line) and moves to the heap when it outgrows it; buf_free() frees only a heap buffer. */
#define LINE_BUFFER 512

typedef struct {
  char *data;
  size_t len, size;
  int on_heap;
} buffer;

#define BUFFER_ON(stack) { (stack), 0, sizeof(stack), FALSE }

static int buf_grow(buffer *b, size_t extra)
{ if ( b->len + extra <= b->size ) return TRUE;
  size_t size = b->size ? b->size : 256;
  while ( size < b->len + extra ) size *= 2;
  char *data = b->on_heap ? realloc(b->data, size) : malloc(size);
  if ( !data ) return FALSE;
  if ( !b->on_heap && b->len ) memcpy(data, b->data, b->len);
  b->data = data;
  b->size = size;
  b->on_heap = TRUE;
  return TRUE;
}

static int buf_add(buffer *b, const char *s, size_t n);

static void buf_free(buffer *b)
{ if ( b->on_heap ) free(b->data);
}

/* An integer in decimal, as snprintf("%lld") writes it. */
static int buf_int64(buffer *b, int64_t i)
{ char digits[24];
  char *p = digits + sizeof(digits);
  uint64_t u = i < 0 ? (uint64_t)0 - (uint64_t)i : (uint64_t)i;
  do { *--p = (char)('0' + u % 10); u /= 10; } while ( u );
  if ( i < 0 ) *--p = '-';
  return buf_add(b, p, (size_t)(digits + sizeof(digits) - p));
}

static int buf_add(buffer *b, const char *s, size_t n)
{ if ( !buf_grow(b, n) ) return FALSE;
  memcpy(b->data + b->len, s, n);
  b->len += n;
  return TRUE;
}

static int buf_text(buffer *b, const char *s)
{ return buf_add(b, s, strlen(s));
}

/* The term as writeq/1 writes it, UTF-8 encoded, into a fresh malloc()ed text. */
static int written(term_t t, int flags, char **text, size_t *len)
{ *text = NULL;
  *len = 0;
  IOSTREAM *s = Sopenmem(text, len, "w");
  if ( !s ) return FALSE;
  s->encoding = ENC_UTF8;
  int ok = PL_write_term(s, t, 1200, flags);
  ok = (Sclose(s) == 0) && ok;
  if ( !ok ) { free(*text); *text = NULL; }
  return ok;
}

/* The inside of a JSON string: `"`, `\`, and control characters as \n, \t or \u00xx. */
static int json_escaped(buffer *b, const char *s, size_t n)
{ static const char hex[] = "0123456789abcdef";
  for (size_t i = 0; i < n; i++)
  { unsigned char c = (unsigned char)s[i];
    char esc[6];
    if ( c == '"' || c == '\\' )
    { esc[0] = '\\'; esc[1] = (char)c;
      if ( !buf_add(b, esc, 2) ) return FALSE;
    } else if ( c == '\n' )
    { if ( !buf_add(b, "\\n", 2) ) return FALSE;
    } else if ( c == '\t' )
    { if ( !buf_add(b, "\\t", 2) ) return FALSE;
    } else if ( c < 0x20 )
    { esc[0] = '\\'; esc[1] = 'u'; esc[2] = '0'; esc[3] = '0';
      esc[4] = hex[c >> 4]; esc[5] = hex[c & 0xf];
      if ( !buf_add(b, esc, 6) ) return FALSE;
    } else if ( !buf_add(b, (const char *)&s[i], 1) ) return FALSE;
  }
  return TRUE;
}

/* A time: an integer, or a finite float written as write/1 writes it. */
static int json_time_text(buffer *b, term_t t)
{ if ( PL_is_integer(t) )
  { int64_t i;
    if ( !PL_get_int64(t, &i) ) return FALSE;       /* a big integer: rtl_io.pl */
    return buf_int64(b, i);
  }
  double d;
  if ( !PL_is_float(t) || !PL_get_float(t, &d) || !isfinite(d) ) return FALSE;
  char *text;
  size_t len;
  /* the text write/1 writes (float_format), without a stream */
  if ( !PL_get_nchars(t, &len, &text, CVT_FLOAT|BUF_STACK) ) return FALSE;
  return buf_add(b, text, len);
}

/* An atom as a JSON string: an ASCII atom from its characters, any other as UTF-8. */
static int json_atom(buffer *b, atom_t a)
{ size_t len;
  const char *s = PL_atom_nchars(a, &len);
  if ( s )
  { size_t i = 0;
    while ( i < len && (unsigned char)s[i] < 0x80 ) i++;
    if ( i == len ) return buf_add(b, "\"", 1) && json_escaped(b, s, len) && buf_add(b, "\"", 1);
  }
  term_t t = PL_new_term_ref();
  char *text;
  return PL_put_atom(t, a) && PL_get_nchars(t, &len, &text, CVT_ATOM|REP_UTF8|BUF_STACK) &&
         buf_add(b, "\"", 1) && json_escaped(b, text, len) && buf_add(b, "\"", 1);
}

/* A plain term, written here as writeq/1 writes it, without a stream: integers that fit 64
   bits, finite floats (written by write/1), atoms that are identifiers (a lowercase ASCII
   letter, then letters, digits and _: never quoted, and written as they are in any position,
   operators included), [], proper and partial lists of plain terms, and compound terms whose
   name is such an identifier and whose arity is not 1 or 2 (no operator has another arity,
   so writeq/1 writes them as name(Arg,...), without spaces), and unbound variables that are
   not attributed: named `_123` by varName() of SWI-Prolog, which PL_write_term() calls too, so
   the name (the variable's offset in its stack) is the one writeq/1 writes at that moment.
   Fails for any other term, which PL_write_term() then writes. Nothing it writes needs
   escaping in a JSON string. */
static int plain_atom(atom_t a, buffer *b)
{ size_t len;
  const char *s = PL_atom_nchars(a, &len);
  if ( !s || len == 0 || !is_lower(s[0]) ) return FALSE;
  for (size_t i = 1; i < len; i++)
    if ( !is_alnum(s[i]) ) return FALSE;
  return buf_add(b, s, len);
}

static int plain_term(buffer *b, term_t t, int depth)
{ int64_t i;
  atom_t name;
  size_t arity;

  if ( depth > MAX_NESTING ) return FALSE;
  switch ( PL_term_type(t) )
  { case PL_INTEGER:
      if ( !PL_get_int64(t, &i) ) return FALSE;     /* a big integer */
      return buf_int64(b, i);
    case PL_FLOAT:
      return json_time_text(b, t);                  /* finite floats only */
    case PL_ATOM:
      return PL_get_atom(t, &name) && plain_atom(name, b);
    case PL_NIL:
      return buf_add(b, "[]", 2);
    case PL_LIST_PAIR:
    { term_t head = PL_new_term_ref(), tail = PL_copy_term_ref(t);
      size_t cells;
      if ( PL_skip_list(t, 0, &cells) == PL_CYCLIC_TERM ) return FALSE;  /* it would never end */
      if ( !buf_add(b, "[", 1) ) return FALSE;
      for (int first = TRUE; PL_get_list(tail, head, tail); first = FALSE)
      { if ( (!first && !buf_add(b, ",", 1)) || !plain_term(b, head, depth + 1) ) return FALSE;
      }
      if ( !PL_get_nil(tail) && (!buf_add(b, "|", 1) || !plain_term(b, tail, depth + 1)) )
        return FALSE;
      return buf_add(b, "]", 1);
    }
    case PL_TERM:
    { if ( !PL_get_name_arity(t, &name, &arity) || arity == 1 || arity == 2 ) return FALSE;
      if ( !plain_atom(name, b) || !buf_add(b, "(", 1) ) return FALSE;
      term_t arg = PL_new_term_ref();
      for (size_t k = 1; k <= arity; k++)
      { if ( !PL_get_arg(k, t, arg) || (k > 1 && !buf_add(b, ",", 1)) || !plain_term(b, arg, depth + 1) )
          return FALSE;
      }
      return buf_add(b, ")", 1);
    }
    case PL_VARIABLE:                               /* its name, as every writer names it */
    { const char *name;
      size_t len;
      if ( PL_is_attvar(t) ) return FALSE;
      return PL_get_nchars(t, &len, (char **)&name, CVT_VARIABLE|BUF_STACK) && buf_add(b, name, len);
    }
    default:
      return FALSE;
  }
}

/* The output line of the event into b (UTF-8, without a newline). */
static int event_json(buffer *b, term_t event, term_t start, term_t end)
{ char *text;
  size_t len;
  int ok;

  if ( !buf_text(b, "{\"event\": \"") ) return FALSE;
  size_t mark = b->len;
  fid_t fid = PL_open_foreign_frame();
  int plain = plain_term(b, event, 0);
  PL_discard_foreign_frame(fid);
  if ( !plain )
  { b->len = mark;
    if ( !written(event, PL_WRT_QUOTED|PL_WRT_NUMBERVARS|PL_WRT_CHARESCAPES, &text, &len) )
      return FALSE;
    ok = json_escaped(b, text, len);
    free(text);
    if ( !ok ) return FALSE;
  }
  return buf_text(b, "\", \"start\": ") &&
         json_time_text(b, start) &&
         buf_text(b, ", \"end\": ") &&
         json_time_text(b, end) &&
         buf_text(b, "}");
}

static foreign_t
pl_fast_event_json(term_t event, term_t start, term_t end, term_t json)
{ char stack[LINE_BUFFER];
  buffer b = BUFFER_ON(stack);
  int ok = event_json(&b, event, start, end) &&
           PL_unify_chars(json, PL_STRING|REP_UTF8, b.len, b.data);
  buf_free(&b);
  return ok;
}

/* rtl_fast_write_event(+Stream, +Event, +Start, +End): the line and a newline written to
   Stream, which must be a UTF-8 text stream (else it fails, as for times that are not
   finite, before anything is written). */
static foreign_t
pl_fast_write_event(term_t stream, term_t event, term_t start, term_t end)
{ char stack[LINE_BUFFER];
  buffer b = BUFFER_ON(stack);
  IOSTREAM *s;
  int ok = event_json(&b, event, start, end) && buf_text(&b, "\n");

  if ( ok )
  { if ( !PL_get_stream(stream, &s, SIO_OUTPUT) )
    { buf_free(&b);
      return FALSE;
    }
    if ( s->encoding == ENC_UTF8 )
      ok = Sfwrite(b.data, 1, b.len, s) == b.len;
    else
      ok = FALSE;
    ok = PL_release_stream(s) && ok;
  }
  buf_free(&b);
  return ok;
}

/* ---- output data (rtl_io:rtl_output_data/2) ---------------------------------------- */

static atom_t atom_minus, atom_echo;
static functor_t functor_event5, functor_json1, functor_echo1;

/* A text (atom or string) as a JSON string, escaped as json_escaped() escapes. */
static int json_string_of(buffer *b, term_t t, int flags)
{ char *s;
  size_t len;
  if ( !PL_get_nchars(t, &len, &s, flags|REP_UTF8|BUF_STACK) ) return FALSE;
  return buf_add(b, "\"", 1) && json_escaped(b, s, len) && buf_add(b, "\"", 1);
}

static int term_data(buffer *b, term_t t, int depth);

static int data_items(buffer *b, term_t list, int depth)
{ term_t head = PL_new_term_ref(), tail = PL_copy_term_ref(list);
  while ( PL_get_list(tail, head, tail) )
  { if ( !buf_add(b, ",", 1) || !term_data(b, head, depth + 1) ) return FALSE;
  }
  return TRUE;
}

/* A term as data, as term_data//1 of rtl_io.pl writes it. */
static int term_data(buffer *b, term_t t, int depth)
{ int64_t i;
  atom_t name;
  size_t arity;

  if ( depth > MAX_NESTING ) return FALSE;
  switch ( PL_term_type(t) )
  { case PL_INTEGER:
      if ( !PL_get_int64(t, &i) ) return FALSE;     /* a big integer: rtl_io.pl */
      return buf_int64(b, i);
    case PL_FLOAT:
    { double d;
      if ( !PL_get_float(t, &d) ) return FALSE;
      if ( isnan(d) ) return buf_text(b, "[\"f\",\"nan\"]");
      if ( isinf(d) ) return buf_text(b, d > 0 ? "[\"f\",\"inf\"]" : "[\"f\",\"-inf\"]");
      return json_time_text(b, t);
    }
    case PL_ATOM:
      return PL_get_atom(t, &name) && json_atom(b, name);
    case PL_NIL:
      return buf_text(b, "[\"l\"]");
    case PL_STRING:
      return buf_text(b, "[\"s\",") && json_string_of(b, t, CVT_STRING) && buf_add(b, "]", 1);
    case PL_LIST_PAIR:
    { size_t cells;
      if ( PL_skip_list(t, 0, &cells) == PL_LIST )
        return buf_text(b, "[\"l\"") && data_items(b, t, depth) && buf_add(b, "]", 1);
      term_t head = PL_new_term_ref(), tail = PL_new_term_ref();    /* a partial list: '[|]'(H, T) */
      return PL_get_list(t, head, tail) && buf_text(b, "[\"c\",\"[|]\",") && term_data(b, head, depth + 1) &&
             buf_add(b, ",", 1) && term_data(b, tail, depth + 1) && buf_add(b, "]", 1);
    }
    case PL_TERM:
    { if ( !PL_get_name_arity(t, &name, &arity) ) return FALSE;
      term_t arg = PL_new_term_ref();
      if ( !buf_text(b, "[\"c\",") || !json_atom(b, name) ) return FALSE;
      for (size_t k = 1; k <= arity; k++)
      { if ( !PL_get_arg(k, t, arg) || !buf_add(b, ",", 1) || !term_data(b, arg, depth + 1) ) return FALSE;
      }
      return buf_add(b, "]", 1);
    }
    default:                                        /* variables, dicts, blobs: rtl_io.pl */
      return FALSE;
  }
}

/* The writeq text of an event as a JSON string. */
static int event_text(buffer *b, term_t event)
{ char *text;
  size_t len;
  if ( !buf_add(b, "\"", 1) ) return FALSE;
  size_t mark = b->len;
  fid_t fid = PL_open_foreign_frame();
  int plain = plain_term(b, event, 0);
  PL_discard_foreign_frame(fid);
  if ( !plain )
  { b->len = mark;
    if ( !written(event, PL_WRT_QUOTED|PL_WRT_NUMBERVARS|PL_WRT_CHARESCAPES, &text, &len) ) return FALSE;
    int ok = json_escaped(b, text, len);
    free(text);
    if ( !ok ) return FALSE;
  }
  return buf_add(b, "\"", 1);
}

/* One record: its output into b, its term as data into d. */
static int output_record(buffer *b, buffer *d, term_t record)
{ term_t a = PL_new_term_ref();
  if ( PL_is_functor(record, functor_json1) )
  { char *s;
    size_t len;
    return PL_get_arg(1, record, a) && PL_get_nchars(a, &len, &s, CVT_STRING|CVT_ATOM|REP_UTF8|BUF_STACK) &&
           buf_add(b, s, len) && buf_text(d, "null");
  }
  if ( !PL_is_functor(record, functor_event5) ) return FALSE;
  term_t event = PL_new_term_ref(), start = PL_new_term_ref(), end = PL_new_term_ref(),
         consumer = PL_new_term_ref(), op = PL_new_term_ref();
  atom_t c, o;
  if ( !PL_get_arg(1, record, event) || !PL_get_arg(2, record, start) || !PL_get_arg(3, record, end) ||
       !PL_get_arg(4, record, consumer) || !PL_get_arg(5, record, op) )
    return FALSE;
  if ( !PL_get_atom(op, &o) || (o != atom_add && o != atom_retract) ) return FALSE;
  if ( !term_data(d, event, 0) ) return FALSE;
  int no_consumer = PL_get_atom(consumer, &c) && c == atom_minus;
  if ( no_consumer && o == atom_add )
    return buf_add(b, "[", 1) && event_text(b, event) && buf_add(b, ",", 1) && json_time_text(b, start) &&
           buf_add(b, ",", 1) && json_time_text(b, end) && buf_add(b, "]", 1);
  if ( !buf_text(b, "{\"event\": ") || !event_text(b, event) || !buf_text(b, ", \"start\": ") ||
       !json_time_text(b, start) || !buf_text(b, ", \"end\": ") || !json_time_text(b, end) )
    return FALSE;
  if ( !no_consumer )
  { if ( PL_is_functor(consumer, functor_echo1) )
    { term_t what = PL_new_term_ref();
      atom_t w;
      if ( !PL_get_arg(1, consumer, what) || !PL_get_atom(what, &w) || w != atom_echo ) return FALSE;
      if ( !buf_text(b, ", \"input\": true") ) return FALSE;
    } else if ( PL_is_atom(consumer) )              /* (a consumer is an atom: ~w writes its text) */
    { if ( !buf_text(b, ", \"consumer\": ") || !json_string_of(b, consumer, CVT_ATOM) ) return FALSE;
    } else
      return FALSE;
  }
  if ( o == atom_retract && !buf_text(b, ", \"op\": \"retract\"") ) return FALSE;
  return buf_add(b, "}", 1);
}

/* rtl_fast_output_data(+Records, -Json): the outputs line, a newline, the terms line. */
static foreign_t
pl_fast_output_data(term_t records, term_t json)
{ char stack[4096], data_stack[4096];
  buffer b = BUFFER_ON(stack), d = BUFFER_ON(data_stack);
  term_t head = PL_new_term_ref(), tail = PL_copy_term_ref(records);
  int ok = buf_add(&b, "[", 1) && buf_add(&d, "[", 1);
  for (int first = TRUE; ok && PL_get_list(tail, head, tail); first = FALSE)
  { fid_t fid = PL_open_foreign_frame();
    ok = (first || (buf_add(&b, ",", 1) && buf_add(&d, ",", 1))) && output_record(&b, &d, head);
    PL_close_foreign_frame(fid);
  }
  ok = ok && PL_get_nil(tail) && buf_text(&b, "]\n") && buf_add(&d, "]", 1) && buf_add(&b, d.data, d.len) &&
       PL_unify_chars(json, PL_STRING|REP_UTF8, b.len, b.data);
  buf_free(&b);
  buf_free(&d);
  return ok;
}

/* rtl_fast_plain_text(+Term, -Text): Term as plain_term() writes it; fails for a term that is
   not plain (the writers above hand it to PL_write_term()). For tests. */
static foreign_t
pl_fast_plain_text(term_t term, term_t text)
{ char stack[LINE_BUFFER];
  buffer b = BUFFER_ON(stack);
  fid_t fid = PL_open_foreign_frame();
  int ok = plain_term(&b, term, 0);
  PL_discard_foreign_frame(fid);
  ok = ok && PL_unify_chars(text, PL_STRING|REP_UTF8, b.len, b.data);
  buf_free(&b);
  return ok;
}

install_t
install_rtl_fastread(void)
{ atom_add = PL_new_atom("add");                  /* registered: never garbage collected */
  atom_retract = PL_new_atom("retract");
  atom_minus = PL_new_atom("-");
  atom_echo = PL_new_atom("input");
  functor_event5 = PL_new_functor(PL_new_atom("event"), 5);
  functor_json1 = PL_new_functor(PL_new_atom("json"), 1);
  functor_echo1 = PL_new_functor(PL_new_atom("echo"), 1);
  PL_register_foreign("rtl_fast_read_lines", 6, pl_fast_read_lines, 0);
  PL_register_foreign("rtl_fast_event_line", 8, pl_fast_event_line, 0);
  PL_register_foreign("rtl_fast_event_json", 4, pl_fast_event_json, 0);
  PL_register_foreign("rtl_fast_write_event", 4, pl_fast_write_event, 0);
  PL_register_foreign("rtl_fast_plain_text", 2, pl_fast_plain_text, 0);
  PL_register_foreign("rtl_fast_output_data", 2, pl_fast_output_data, 0);
}
