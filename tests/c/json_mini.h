/* Minimal JSON reader for the C tests: parses a whole document into a flat, pre-order token array
 * (no heap; the caller provides the array). Enough for the protocol/vectors JSON files: objects, arrays,
 * strings (escapes are kept verbatim, the vectors have none), numbers, true/false/null. */
#ifndef JSON_MINI_H
#define JSON_MINI_H

#include <stddef.h>

typedef enum { JSON_NONE = 0, JSON_OBJECT, JSON_ARRAY, JSON_STRING, JSON_NUMBER, JSON_LITERAL } json_type_t;

typedef struct {
    json_type_t type;
    size_t start; /* offsets into the text; strings without their quotes */
    size_t end;
    int count;    /* object: members, array: elements */
    int next;     /* index of the first token after this value (its subtree skipped) */
} json_tok_t;

/* Returns the number of tokens, or -1 (syntax error) / -2 (more than max_toks tokens). */
int json_parse(const char *text, size_t len, json_tok_t *toks, int max_toks);

/* Value of member `key` of object token `obj`, or -1. */
int json_get(const char *text, const json_tok_t *toks, int obj, const char *key);
/* Element n of array token `arr`, or -1. */
int json_at(const json_tok_t *toks, int arr, int n);
/* Token equals the string s (strings and literals). */
int json_eq(const char *text, const json_tok_t *tok, const char *s);
/* Copy a string/number token into buf (NUL-terminated); -1 if it does not fit. */
int json_copy(const char *text, const json_tok_t *tok, char *buf, size_t size);
/* A number token as double (strtod); *ok = 0 if the token is not a number. */
double json_number(const char *text, const json_tok_t *tok, int *ok);

#endif /* JSON_MINI_H */
