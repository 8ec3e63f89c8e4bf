/**
 * @file rec_ring.h
 * @brief Single-producer single-consumer ring of recorded messages in shared memory.
 *
 * The cycle engine (producer) writes one record per message it records; the recorder process
 * (consumer, bench/record/recorder.py) drains them into MCAP. The memory is a MAP_SHARED mapping the
 * bench creates before it forks the recorder, so the two processes see the same ring. The
 * producer never blocks inside the ring: rec_ring_begin() returns NULL when the record does not
 * fit, and the caller decides (the engine drops and counts in real time; in lockstep it waits a
 * bounded time for the recorder, see engine.h).
 *
 * Layout: a 256-octet header (magic, capacity, the producer's head and the consumer's tail on
 * separate cache lines, counters), then `capacity` octets of records. head and tail are
 * monotonic byte counters (position = counter % capacity), so full and empty are never
 * ambiguous. A record is a 16-octet header (payload length, channel, flags, time) followed by
 * the payload, padded to a multiple of 8 octets, and never wraps: when it does not fit before
 * the end, the producer writes a pad record (or, with less than 16 octets left, nothing: the
 * consumer skips a tail shorter than a header) and starts again at 0.
 *
 * Ordering: the producer fills a record, then publishes it with a release store of head; the
 * consumer reads head with acquire, copies the records, then releases tail.
 */
#ifndef REC_RING_H
#define REC_RING_H

#include <stddef.h>
#include <stdint.h>

#define REC_RING_MAGIC 0x48494C52494E4731ull /* "HILRING1" */
#define REC_RING_HEADER_SIZE 256u
#define REC_RING_RECORD_HEADER 16u
#define REC_RING_PAD_CHANNEL 0xFFFFu

typedef struct rec_ring_header {
    uint64_t magic;
    uint64_t capacity;        /* octets of record space after the header */
    uint64_t head;            /* producer: octets published (monotonic) */
    uint8_t pad_head_[40];
    uint64_t tail;            /* consumer: octets consumed (monotonic) */
    uint8_t pad_tail_[56];
    uint64_t records_written; /* producer counters */
    uint64_t records_dropped;
    uint64_t bytes_dropped;
    uint32_t producer_closed; /* the producer will write no more */
    uint32_t reserved_;
    uint8_t pad_end_[96];
} rec_ring_header_t;

/** Header of one record (little-endian host layout; the consumer is on the same host). */
typedef struct rec_ring_record {
    uint32_t length;   /* payload octets */
    uint16_t channel;  /* the channel index the bench registered; 0xFFFF = pad */
    uint16_t flags;    /* reserved, 0 */
    int64_t t_ns;      /* log time relative to the run's start [ns] */
} rec_ring_record_t;

/** Producer/consumer handle over a mapping (the same memory in both processes). */
typedef struct rec_ring {
    rec_ring_header_t *hdr;
    uint8_t *data;
    uint64_t reserve_pos;   /* producer: where the record in progress starts (counter) */
    uint64_t reserve_len;   /* producer: its reserved size incl. header and padding */
} rec_ring_t;

/** Size of a mapping that holds `capacity` octets of records. */
size_t rec_ring_mapping_size(size_t capacity);
/** Format a fresh mapping of mapping_size octets. Returns 0, or -1 if it is too small. */
int rec_ring_format(void *mem, size_t mapping_size);
/** Attach to a formatted mapping. Returns 0, or -1 if the magic or size is wrong. */
int rec_ring_attach(rec_ring_t *r, void *mem, size_t mapping_size);

/* ---- producer ---- */
/** Room for a record of up to max_payload octets: a pointer to its payload, or NULL if full
 *  (nothing is reserved then). */
uint8_t *rec_ring_begin(rec_ring_t *r, size_t max_payload);
/** Publish the record begun last with its real payload length (<= max_payload). */
void rec_ring_commit(rec_ring_t *r, uint16_t channel, int64_t t_ns, size_t payload_len);
/** begin + copy + commit; returns 0, or -1 (and counts a drop) if it does not fit. */
int rec_ring_write(rec_ring_t *r, uint16_t channel, int64_t t_ns, const void *payload,
                   size_t len);
/** Count a record the producer had to drop (it did not fit). */
void rec_ring_count_drop(rec_ring_t *r, size_t len);
/** The producer is done (the consumer drains what is left and may stop). */
void rec_ring_close(rec_ring_t *r);

/* ---- consumer ---- */
/** Octets published and not yet consumed. */
uint64_t rec_ring_pending(const rec_ring_t *r);
/**
 * Copy whole records (16-octet header + payload padded to 8) into out[0..cap), skipping pad
 * records, and consume them. Returns the octets copied (0: nothing pending, or cap smaller than
 * the next record -- give cap >= 16 + the largest record).
 */
size_t rec_ring_read(rec_ring_t *r, uint8_t *out, size_t cap);

#endif
