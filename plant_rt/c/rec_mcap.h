/**
 * @file rec_mcap.h
 * @brief The recorder's fast path: a batch of ring records (rec_ring_read's output) turned
 * into MCAP Message records in one call, so the recorder process spends no Python per message
 * (bench/record/recorder.py; the bytes are exactly what mcap's own Writer writes for each message).
 *
 * MCAP Message record (mcap.dev/spec): opcode 0x05, u64 length, u16 channel id, u32 sequence,
 * u64 log time, u64 publish time, data; all little-endian. The serial byte capture's records
 * (bench/record/serial_capture.py: u64 t_ns, u8 direction, u32 length, octets) are written to a
 * second buffer for the recorder to append to the capture file.
 *
 * Host-only C99. No heap.
 */
#ifndef REC_MCAP_H
#define REC_MCAP_H

#include <stddef.h>
#include <stdint.h>

/** One message written: where its record starts in out[], its channel and log time. */
typedef struct {
    uint64_t offset;
    uint64_t log_time;
    uint16_t channel_id;
    uint16_t pad_[3];
} rec_mcap_entry_t;

#define REC_MCAP_RAW (-1)     /* channel_map value: the serial byte capture */
#define REC_MCAP_SKIP (-2)    /* channel_map value: not a channel (skipped) */
#define REC_MCAP_MESSAGE_OVERHEAD 31u /* opcode, length, channel, sequence, two times */

/** What a call produced, and how much of the input it consumed. */
typedef struct {
    size_t in_used;      /* input octets consumed (whole records) */
    size_t out_len;      /* MCAP Message records written to out */
    size_t n_entries;    /* messages written (entries[0..n_entries)) */
    size_t raw_len;      /* serial capture records written to raw_out */
    int stopped_at_limit; /* out passed `limit` octets: the caller closes its chunk now */
} rec_mcap_result_t;

/**
 * Convert ring records from in[0..n_in) (each: rec_ring_record_t header, payload, padding to 8).
 * channel_map[ring channel] = the MCAP channel id (>= 0), REC_MCAP_RAW or REC_MCAP_SKIP;
 * channels >= n_map are skipped. seqs[ring channel] is each channel's next sequence number
 * (advanced). log time = start_ns + the record's t_ns. Stops before a record that does not fit
 * out, entries or raw_out, and right after the message that takes out past `limit` octets (as
 * mcap's Writer closes a chunk once it holds more than its chunk size).
 */
void rec_to_mcap(const uint8_t *in, size_t n_in, const int32_t *channel_map, size_t n_map,
                 uint32_t *seqs, int64_t start_ns, size_t limit, uint8_t *out, size_t out_cap,
                 rec_mcap_entry_t *entries, size_t entries_cap, uint8_t *raw_out, size_t raw_cap,
                 rec_mcap_result_t *res);

#endif
