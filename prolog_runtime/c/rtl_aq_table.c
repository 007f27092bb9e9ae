/*  rtl_aq_table: the answer tables of active queries (rtl_aq_table.pl, rtl_aq.pl).

    A table is a blob of type `aq_answers` holding a set of terms, each with an integer
    value (its rank in rtl_aq.pl). Terms are equal when they are variants: a term is kept
    as its external record (PL_record_external/2), whose bytes number the variables in the
    order they first appear and spell atoms by their text, so two terms have the same bytes
    exactly when they are variants (0.0 and -0.0, 1 and 1.0 stay different, as for
    SWI-Prolog's tries). The records are found through an open-addressing hash table of
    their bytes (linear probing, deletion by backward shift: no tombstones), with the
    entries themselves in an array that enumeration walks (records of up to 24 bytes
    inside their entry).

    Terms with attributed variables and cyclic terms are refused with the type errors of
    trie_insert/3. The tables are not shared between threads (rtl_aq.pl runs in one).

      aqt_new(-Table)
      aqt_add(+Table, +Term, +Value, -New)  New = true: Term was absent and is stored with
                                            Value; New = false: it was there, and its value
                                            V > 0 is now -V (derived more than once)
      aqt_insert(+Table, +Term, +Value)     store Term with Value; fails if it is there
      aqt_lookup(+Table, +Term, -Value)     semidet
      aqt_delete(+Table, +Term, -Value)     remove Term; fails if it is not there
      aqt_entries(+Table, -Pairs)           every Term-Value, in no particular order
      aqt_count(+Table, -Count)
      aqt_ground(+Table)                    semidet: every stored term is ground
      aqt_destroy(+Table)                   free the entries (the blob itself goes at atom
                                            garbage collection); later use raises an
                                            existence error
*/

#include <SWI-Stream.h>
#include <SWI-Prolog.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static atom_t ATOM_true, ATOM_false;

#define INLINE 24                   /* records this long are kept in the entry itself */

typedef struct entry
{ int64_t   value;
  uint32_t  length;                 /* of the record; NONGROUND: the term has variables */
  uint32_t  hash;
  union
  { char   *pointer;                /* PL_record_external() bytes */
    char    bytes[INLINE];
  } record;
} entry;

#define NONGROUND 0x80000000U
#define DELETED   0x7fffffffU       /* the length of a removed entry */
#define BYTES(length) ((length) & ~NONGROUND)
#define RECORD(e) (BYTES((e)->length) <= INLINE ? (e)->record.bytes : (e)->record.pointer)

/* A slot holds the entry's hash beside its index, so that a probe that passes other
   entries reads the slots only. */
#define SLOT(index1, hash) ((uint64_t)(hash) << 32 | (uint32_t)(index1))
#define SLOT_INDEX(s) ((size_t)(uint32_t)(s) - 1)
#define SLOT_HASH(s) ((uint32_t)((s) >> 32))

/* Removed entries stay in the entries array as holes (removal touches no other entry)
   until it is full: then it is compacted, and doubled when more than half of it is live. */
typedef struct table
{ entry    *entries;                /* 0 .. used-1, holes included */
  size_t    used;
  size_t    live;                   /* entries that are not holes */
  size_t    capacity;               /* of entries */
  uint64_t *slots;                  /* SLOT(index + 1 into entries, hash), 0 = empty */
  size_t    nslots;                 /* a power of 2, at least 2 * capacity */
  size_t    nonground;              /* entries with variables */
  int       destroyed;
} table;

static void
free_record(entry *e)
{ if ( e->length != DELETED && BYTES(e->length) > INLINE )
    PL_erase_external(e->record.pointer);
  e->length = DELETED;
}

static void
free_entries(table *t)
{ for (size_t i = 0; i < t->used; i++)
    free_record(&t->entries[i]);
  free(t->entries);
  free(t->slots);
  t->entries = NULL;
  t->slots = NULL;
  t->used = t->live = t->capacity = t->nslots = t->nonground = 0;
}

static int
release_table(atom_t a)
{ table *t = *(table **)PL_blob_data(a, NULL, NULL);
  free_entries(t);
  free(t);
  return TRUE;
}

static int
write_table(IOSTREAM *s, atom_t a, int flags)
{ table *t = *(table **)PL_blob_data(a, NULL, NULL);
  (void)flags;
  Sfprintf(s, "<aq_answers>(%p)", (void *)t);
  return TRUE;
}

static PL_blob_t table_blob =
{ .magic   = PL_BLOB_MAGIC,
  .flags   = 0,                     /* the blob's data: the table's address */
  .name    = "aq_answers",
  .release = release_table,         /* at atom garbage collection */
  .write   = write_table
};

static int
get_table(term_t t, table **tp)
{ void *data;
  PL_blob_t *type;

  if ( PL_get_blob(t, &data, NULL, &type) && type == &table_blob )
  { table *tab = *(table **)data;
    if ( tab->destroyed )
      return PL_existence_error("aq_answers", t);
    *tp = tab;
    return TRUE;
  }
  return PL_type_error("aq_answers", t);
}

static uint32_t
hash_bytes(const char *s, size_t n)
{ uint64_t h = 0xcbf29ce484222325ULL;       /* FNV-1a */
  for (size_t i = 0; i < n; i++)
  { h ^= (unsigned char)s[i];
    h *= 0x100000001b3ULL;
  }
  h ^= h >> 33;                             /* MurmurHash3's finaliser: FNV's low bits */
  h *= 0xff51afd7ed558ccdULL;               /* depend on the low bits of the input only */
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ULL;
  h ^= h >> 33;
  return (uint32_t)h;
}

static int
has_attvar(term_t t)
{ term_t arg = PL_new_term_ref();
  size_t arity;
  atom_t name;

  for (;;)
  { if ( PL_is_variable(t) )
      return PL_is_attvar(t);
    if ( !PL_get_name_arity(t, &name, &arity) || arity == 0 )
      return FALSE;
    for (size_t i = 1; i < arity; i++)
    { _PL_get_arg(i, t, arg);
      if ( has_attvar(arg) )
        return TRUE;
    }
    _PL_get_arg(arity, t, arg);           /* the last argument in the loop: lists */
    t = arg;
    arg = PL_new_term_ref();
  }
}

/* The key of a term: its record, length (with NONGROUND) and hash, or FALSE with an
   exception. */
static int
term_key(term_t t, char **record, size_t *length, uint32_t *hash)
{ fid_t fid = PL_open_foreign_frame();
  int ok = TRUE, ground = TRUE;

  if ( !PL_is_acyclic(t) )
    ok = PL_type_error("acyclic_term", t);
  else if ( !(ground = PL_is_ground(t)) && has_attvar(t) )
  { term_t culprit = PL_new_term_ref();
    ok = PL_put_term(culprit, t) && PL_type_error("free_of_attvar", culprit);
  }
  if ( ok )
  { *record = PL_record_external(t, length);
    if ( !*record )
      ok = FALSE;
    else if ( *length >= DELETED )
    { PL_erase_external(*record);
      ok = PL_resource_error("memory");
    } else
    { *hash = hash_bytes(*record, *length);
      if ( !ground )
        *length |= NONGROUND;
    }
  }
  PL_close_foreign_frame(fid);
  return ok;
}

/* The slot holding the record, or the empty slot where it would go. */
static size_t
find_slot(const table *t, const char *record, size_t length, uint32_t hash)
{ size_t mask = t->nslots - 1;
  size_t i = hash & mask;

  for (;;)
  { uint64_t s = t->slots[i];
    if ( s == 0 )
      return i;
    if ( SLOT_HASH(s) == hash )
    { const entry *e = &t->entries[SLOT_INDEX(s)];
      if ( e->length == length && memcmp(RECORD(e), record, BYTES(length)) == 0 )
        return i;
    }
    i = (i + 1) & mask;
  }
}

static int
grow(table *t)
{ size_t capacity = t->capacity == 0 ? 8 : t->live * 2 > t->capacity ? t->capacity * 2
                                                                     : t->capacity;
  size_t nslots = capacity * 2;
  size_t w = 0;

  for (size_t k = 0; k < t->used; k++)              /* compact */
    if ( t->entries[k].length != DELETED )
      t->entries[w++] = t->entries[k];
  t->used = w;
  if ( capacity != t->capacity )
  { entry *entries = realloc(t->entries, capacity * sizeof(entry));
    if ( !entries )
      return FALSE;
    t->entries = entries;
    uint64_t *slots = calloc(nslots, sizeof(uint64_t));
    if ( !slots )
      return FALSE;
    free(t->slots);
    t->slots = slots;
    t->nslots = nslots;
    t->capacity = capacity;
  } else
    memset(t->slots, 0, nslots * sizeof(uint64_t));
  for (size_t k = 0; k < t->used; k++)
  { size_t mask = nslots - 1, i = t->entries[k].hash & mask;
    while ( t->slots[i] )
      i = (i + 1) & mask;
    t->slots[i] = SLOT(k + 1, t->entries[k].hash);
  }
  return TRUE;
}

/* Store a new entry at the empty slot i (found for this record). */
static int
add_entry(table *t, size_t i, char *record, size_t length, uint32_t hash, int64_t value)
{ if ( t->used == t->capacity )
  { if ( t->capacity >= UINT32_MAX / 4 || !grow(t) )
    { PL_erase_external(record);
      return PL_resource_error("memory");
    }
    i = find_slot(t, record, length, hash);
  }
  entry *e = &t->entries[t->used];
  e->value = value;
  e->length = (uint32_t)length;
  e->hash = hash;
  if ( BYTES(length) <= INLINE )
  { memcpy(e->record.bytes, record, BYTES(length));
    PL_erase_external(record);
  } else
    e->record.pointer = record;
  if ( length & NONGROUND )
    t->nonground++;
  t->live++;
  t->slots[i] = SLOT(++t->used, hash);
  return TRUE;
}

/* Empty slot i, shifting back the slots after it that probed past it, and leave a hole
   in place of its entry. */
static void
remove_slot(table *t, size_t i)
{ size_t mask = t->nslots - 1;
  entry *e = &t->entries[SLOT_INDEX(t->slots[i])];
  size_t j = i;

  if ( e->length & NONGROUND )
    t->nonground--;
  free_record(e);
  t->live--;
  t->slots[i] = 0;
  for (;;)
  { j = (j + 1) & mask;
    uint64_t s = t->slots[j];
    if ( s == 0 )
      break;
    size_t home = SLOT_HASH(s) & mask;
    /* move s back to i unless its home lies cyclically in (i, j] */
    if ( (j > i) ? (home <= i || home > j) : (home <= i && home > j) )
    { t->slots[i] = s;
      t->slots[j] = 0;
      i = j;
    }
  }
}

/* Look the term up: FALSE with an exception, else TRUE with *found and the slot. */
static int
lookup(table *t, term_t term, char **record, size_t *length, uint32_t *hash,
       size_t *slot, int *found)
{ if ( !term_key(term, record, length, hash) )
    return FALSE;
  if ( t->nslots == 0 && !grow(t) )
  { PL_erase_external(*record);
    return PL_resource_error("memory");
  }
  *slot = find_slot(t, *record, *length, *hash);
  *found = t->slots[*slot] != 0;
  return TRUE;
}

static foreign_t
pl_aqt_new(term_t out)
{ table *t = calloc(1, sizeof(table));
  if ( !t )
    return PL_resource_error("memory");
  return PL_unify_blob(out, &t, sizeof(t), &table_blob);
}

static foreign_t
pl_aqt_add(term_t tt, term_t term, term_t value, term_t new)
{ table *t;
  int64_t v;
  char *record;
  size_t length, slot;
  uint32_t hash;
  int found;

  if ( !get_table(tt, &t) || !PL_get_int64_ex(value, &v) ||
       !lookup(t, term, &record, &length, &hash, &slot, &found) )
    return FALSE;
  if ( found )
  { PL_erase_external(record);
    entry *e = &t->entries[SLOT_INDEX(t->slots[slot])];
    if ( e->value > 0 )
      e->value = -e->value;
    return PL_unify_atom(new, ATOM_false);
  }
  return add_entry(t, slot, record, length, hash, v) && PL_unify_atom(new, ATOM_true);
}

static foreign_t
pl_aqt_insert(term_t tt, term_t term, term_t value)
{ table *t;
  int64_t v;
  char *record;
  size_t length, slot;
  uint32_t hash;
  int found;

  if ( !get_table(tt, &t) || !PL_get_int64_ex(value, &v) ||
       !lookup(t, term, &record, &length, &hash, &slot, &found) )
    return FALSE;
  if ( found )
  { PL_erase_external(record);
    return FALSE;
  }
  return add_entry(t, slot, record, length, hash, v);
}

static foreign_t
pl_aqt_lookup(term_t tt, term_t term, term_t value)
{ table *t;
  char *record;
  size_t length, slot;
  uint32_t hash;
  int found;

  if ( !get_table(tt, &t) || !lookup(t, term, &record, &length, &hash, &slot, &found) )
    return FALSE;
  PL_erase_external(record);
  return found && PL_unify_int64(value, t->entries[SLOT_INDEX(t->slots[slot])].value);
}

static foreign_t
pl_aqt_delete(term_t tt, term_t term, term_t value)
{ table *t;
  char *record;
  size_t length, slot;
  uint32_t hash;
  int found;

  if ( !get_table(tt, &t) || !lookup(t, term, &record, &length, &hash, &slot, &found) )
    return FALSE;
  PL_erase_external(record);
  if ( !found )
    return FALSE;
  int64_t v = t->entries[SLOT_INDEX(t->slots[slot])].value;
  remove_slot(t, slot);
  return PL_unify_int64(value, v);
}

static foreign_t
pl_aqt_entries(term_t tt, term_t out)
{ table *t;
  static functor_t minus2 = 0;

  if ( !minus2 )
    minus2 = PL_new_functor(PL_new_atom("-"), 2);
  if ( !get_table(tt, &t) )
    return FALSE;
  term_t list = PL_new_term_ref(), term = PL_new_term_ref();
  term_t value = PL_new_term_ref(), pair = PL_new_term_ref();
  PL_put_nil(list);
  for (size_t i = t->used; i > 0; i--)
  { const entry *e = &t->entries[i - 1];
    if ( e->length == DELETED )
      continue;
    if ( !PL_recorded_external(RECORD(e), term) || !PL_put_int64(value, e->value) ||
         !PL_cons_functor(pair, minus2, term, value) || !PL_cons_list(list, pair, list) )
      return FALSE;
  }
  return PL_unify(out, list);
}

static foreign_t
pl_aqt_count(term_t tt, term_t count)
{ table *t;
  return get_table(tt, &t) && PL_unify_int64(count, (int64_t)t->live);
}

static foreign_t
pl_aqt_ground(term_t tt)
{ table *t;
  return get_table(tt, &t) && t->nonground == 0;
}

static foreign_t
pl_aqt_destroy(term_t tt)
{ table *t;
  if ( !get_table(tt, &t) )
    return FALSE;
  free_entries(t);
  t->destroyed = TRUE;
  return TRUE;
}

install_t
install_rtl_aq_table(void)
{ ATOM_true = PL_new_atom("true");
  ATOM_false = PL_new_atom("false");
  PL_register_foreign("aqt_new", 1, pl_aqt_new, 0);
  PL_register_foreign("aqt_add", 4, pl_aqt_add, 0);
  PL_register_foreign("aqt_insert", 3, pl_aqt_insert, 0);
  PL_register_foreign("aqt_lookup", 3, pl_aqt_lookup, 0);
  PL_register_foreign("aqt_delete", 3, pl_aqt_delete, 0);
  PL_register_foreign("aqt_entries", 2, pl_aqt_entries, 0);
  PL_register_foreign("aqt_count", 2, pl_aqt_count, 0);
  PL_register_foreign("aqt_ground", 1, pl_aqt_ground, 0);
  PL_register_foreign("aqt_destroy", 1, pl_aqt_destroy, 0);
}
