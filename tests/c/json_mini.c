/* Minimal JSON reader, see json_mini.h. */
#include "json_mini.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
    const char *text;
    size_t len;
    size_t pos;
    json_tok_t *toks;
    int max;
    int n;
    int depth;
} json_parser_t;

static void json_skip_ws(json_parser_t *p)
{
    while (p->pos < p->len) {
        char c = p->text[p->pos];
        if (c != ' ' && c != '\t' && c != '\n' && c != '\r') {
            break;
        }
        p->pos++;
    }
}

static int json_new(json_parser_t *p, json_type_t type)
{
    if (p->n >= p->max) {
        return -2;
    }
    p->toks[p->n].type = type;
    p->toks[p->n].start = p->pos;
    p->toks[p->n].end = p->pos;
    p->toks[p->n].count = 0;
    p->toks[p->n].next = p->n + 1;
    return p->n++;
}

static int json_value(json_parser_t *p);

static int json_string(json_parser_t *p)
{
    int t;
    p->pos++; /* opening quote */
    t = json_new(p, JSON_STRING);
    if (t < 0) {
        return t;
    }
    while (p->pos < p->len && p->text[p->pos] != '"') {
        if (p->text[p->pos] == '\\') {
            p->pos++;
        }
        p->pos++;
    }
    if (p->pos >= p->len) {
        return -1;
    }
    p->toks[t].end = p->pos;
    p->pos++; /* closing quote */
    return t;
}

static int json_container(json_parser_t *p, json_type_t type)
{
    char close = (type == JSON_OBJECT) ? '}' : ']';
    int t = json_new(p, type);
    int r;
    if (t < 0) {
        return t;
    }
    if (++p->depth > 64) {
        return -1;
    }
    p->pos++; /* { or [ */
    json_skip_ws(p);
    if (p->pos < p->len && p->text[p->pos] == close) {
        p->pos++;
    } else {
        for (;;) {
            if (type == JSON_OBJECT) {
                json_skip_ws(p);
                if (p->pos >= p->len || p->text[p->pos] != '"') {
                    return -1;
                }
                r = json_string(p);
                if (r < 0) {
                    return r;
                }
                json_skip_ws(p);
                if (p->pos >= p->len || p->text[p->pos] != ':') {
                    return -1;
                }
                p->pos++;
            }
            r = json_value(p);
            if (r < 0) {
                return r;
            }
            p->toks[t].count++;
            json_skip_ws(p);
            if (p->pos < p->len && p->text[p->pos] == ',') {
                p->pos++;
                continue;
            }
            if (p->pos < p->len && p->text[p->pos] == close) {
                p->pos++;
                break;
            }
            return -1;
        }
    }
    p->depth--;
    p->toks[t].end = p->pos;
    p->toks[t].next = p->n;
    return t;
}

static int json_primitive(json_parser_t *p)
{
    char c = p->text[p->pos];
    json_type_t type = (c == '-' || (c >= '0' && c <= '9')) ? JSON_NUMBER : JSON_LITERAL;
    int t = json_new(p, type);
    if (t < 0) {
        return t;
    }
    while (p->pos < p->len) {
        c = p->text[p->pos];
        if (c == ',' || c == '}' || c == ']' || c == ' ' || c == '\t' || c == '\n' || c == '\r') {
            break;
        }
        p->pos++;
    }
    p->toks[t].end = p->pos;
    if (p->toks[t].end == p->toks[t].start) {
        return -1;
    }
    return t;
}

static int json_value(json_parser_t *p)
{
    json_skip_ws(p);
    if (p->pos >= p->len) {
        return -1;
    }
    switch (p->text[p->pos]) {
    case '{':
        return json_container(p, JSON_OBJECT);
    case '[':
        return json_container(p, JSON_ARRAY);
    case '"':
        return json_string(p);
    default:
        return json_primitive(p);
    }
}

int json_parse(const char *text, size_t len, json_tok_t *toks, int max_toks)
{
    json_parser_t p;
    int r;
    p.text = text;
    p.len = len;
    p.pos = 0u;
    p.toks = toks;
    p.max = max_toks;
    p.n = 0;
    p.depth = 0;
    r = json_value(&p);
    if (r < 0) {
        return r;
    }
    json_skip_ws(&p);
    return (p.pos == p.len) ? p.n : -1;
}

int json_eq(const char *text, const json_tok_t *tok, const char *s)
{
    size_t n = tok->end - tok->start;
    return (tok->type == JSON_STRING || tok->type == JSON_LITERAL) && strlen(s) == n
           && strncmp(text + tok->start, s, n) == 0;
}

int json_get(const char *text, const json_tok_t *toks, int obj, const char *key)
{
    int i;
    int k;
    if (obj < 0 || toks[obj].type != JSON_OBJECT) {
        return -1;
    }
    k = obj + 1;
    for (i = 0; i < toks[obj].count; i++) {
        int v = k + 1; /* a key is a string: one token */
        if (json_eq(text, &toks[k], key)) {
            return v;
        }
        k = toks[v].next;
    }
    return -1;
}

int json_at(const json_tok_t *toks, int arr, int n)
{
    int i;
    int k;
    if (arr < 0 || toks[arr].type != JSON_ARRAY || n < 0 || n >= toks[arr].count) {
        return -1;
    }
    k = arr + 1;
    for (i = 0; i < n; i++) {
        k = toks[k].next;
    }
    return k;
}

int json_copy(const char *text, const json_tok_t *tok, char *buf, size_t size)
{
    size_t n = tok->end - tok->start;
    if (n + 1u > size) {
        return -1;
    }
    memcpy(buf, text + tok->start, n);
    buf[n] = '\0';
    return 0;
}

double json_number(const char *text, const json_tok_t *tok, int *ok)
{
    char buf[64];
    char *end = NULL;
    double v;
    *ok = 0;
    if (tok->type != JSON_NUMBER || json_copy(text, tok, buf, sizeof buf) != 0) {
        return 0.0;
    }
    v = strtod(buf, &end);
    *ok = (end != NULL && *end == '\0') ? 1 : 0;
    return v;
}
