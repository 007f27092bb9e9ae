/*  rtl_utf8: an event line read as bytes, decoded as UTF-8 (rtl_lines.pl).

    rtl_utf8_decode(+Bytes, -Result): Bytes is a string of codes 0..255, the bytes of one
    line. Result is the string they encode when they are well-formed UTF-8 (The Unicode
    Standard, table 3-7: no overlong forms, no surrogates, nothing above U+10FFFF), else
    bad(Column, Byte): the first byte that does not start a well-formed character, and its
    column (1 + the characters before it). rtl_lines.pl has the same in Prolog, used when
    this library is not built.

    rtl_read_line_bytes(+Stream, +MaxBytes, -Line): the next line of Stream (read as ISO
    Latin-1: one byte a code), without its newline, as a string of codes 0..255; or
    `too_long` when it has more than MaxBytes bytes (-1: no limit), the rest of the line
    skipped to its newline without being kept; `end_of_file` at the end. At most MaxBytes
    bytes of a line are held.
*/

#include <SWI-Stream.h>
#include <SWI-Prolog.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* The length of the well-formed character at s (at most n bytes), or 0. */
static size_t
character_length(const unsigned char *s, size_t n)
{ unsigned char b = s[0];
  unsigned char lo = 0x80, hi = 0xbf;
  size_t len;

  if ( b < 0x80 ) return 1;
  if ( b >= 0xc2 && b <= 0xdf ) len = 2;
  else if ( b == 0xe0 ) { len = 3; lo = 0xa0; }
  else if ( b == 0xed ) { len = 3; hi = 0x9f; }
  else if ( b >= 0xe1 && b <= 0xef ) len = 3;
  else if ( b == 0xf0 ) { len = 4; lo = 0x90; }
  else if ( b == 0xf4 ) { len = 4; hi = 0x8f; }
  else if ( b >= 0xf1 && b <= 0xf3 ) len = 4;
  else return 0;
  if ( n < len || s[1] < lo || s[1] > hi ) return 0;
  for (size_t i = 2; i < len; i++)
  { if ( s[i] < 0x80 || s[i] > 0xbf ) return 0;
  }
  return len;
}

static foreign_t
pl_utf8_decode(term_t bytes, term_t result)
{ size_t n;
  char *text;

  if ( !PL_get_nchars(bytes, &n, &text, CVT_STRING|CVT_ATOM|CVT_EXCEPTION) )
    return FALSE;
  const unsigned char *s = (const unsigned char *)text;
  size_t column = 1;
  for (size_t i = 0; i < n; column++)
  { size_t len = character_length(s + i, n - i);
    if ( len == 0 )
    { term_t col = PL_new_term_ref(), byte = PL_new_term_ref();
      return PL_put_int64(col, (int64_t)column) && PL_put_integer(byte, s[i]) &&
             PL_unify_term(result, PL_FUNCTOR_CHARS, "bad", 2, PL_TERM, col, PL_TERM, byte);
    }
    i += len;
  }
  return PL_unify_chars(result, PL_STRING|REP_UTF8, n, text);
}

static foreign_t
pl_read_line_bytes(term_t stream, term_t max_bytes, term_t line)
{ IOSTREAM *s;
  long limit;
  char *buf = NULL;
  size_t len = 0, size = 0;
  int too_long = FALSE, ok = TRUE;
  int c = EOF;

  if ( !PL_get_long_ex(max_bytes, &limit) ) return FALSE;
  if ( !PL_get_stream(stream, &s, SIO_INPUT) ) return FALSE;
  if ( s->encoding != ENC_ISO_LATIN_1 && s->encoding != ENC_OCTET )
  { PL_release_stream(s);
    return PL_domain_error("iso_latin_1_stream", stream);
  }
  while ( (c = Sgetc(s)) != EOF && c != '\n' )
  { if ( too_long ) continue;
    if ( limit >= 0 && len >= (size_t)limit ) { too_long = TRUE; continue; }
    if ( len == size )
    { size_t new_size = size ? 2 * size : 256;
      if ( limit >= 0 && new_size > (size_t)limit ) new_size = (size_t)limit;
      char *grown = realloc(buf, new_size);
      if ( !grown ) { ok = FALSE; break; }
      buf = grown;
      size = new_size;
    }
    buf[len++] = (char)c;
  }
  if ( !PL_release_stream(s) ) ok = FALSE;      /* a read error raises here */
  else if ( !ok ) ok = PL_resource_error("memory");
  else if ( c == EOF && len == 0 && !too_long ) ok = PL_unify_atom_chars(line, "end_of_file");
  else if ( too_long ) ok = PL_unify_atom_chars(line, "too_long");
  else ok = PL_unify_chars(line, PL_STRING, len, buf ? buf : "");
  free(buf);
  return ok;
}

install_t
install_rtl_utf8(void)
{ PL_register_foreign("rtl_utf8_decode", 2, pl_utf8_decode, 0);
  PL_register_foreign("rtl_read_line_bytes", 3, pl_read_line_bytes, 0);
}
