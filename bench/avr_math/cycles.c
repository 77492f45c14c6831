/* Cycle-exact runner for the AVR math benchmark (bench.cpp) on simavr.
 *
 * Usage: avr_math_cycles FIRMWARE.elf [--json FILE] [--expect-hash 0xHHHHHHHH]
 *
 * Loads the ELF as an ATmega328P at 16 MHz and watches two I/O registers:
 *   GPIOR1 (data 0x4A): characters of a group name, 0 terminates it and opens the group;
 *   GPIOR0 (data 0x3E): 1 = start of a sample, 2 = end of a sample (cycle counter read at both);
 *   GPIOR2 (data 0x4B): at the end, the firmware's self-check result (number of mismatches,
 *                       0 = pass), then the 4 bytes (LSB first) of its results hash.
 * Exit status 0 only if the self-check passed and, with --expect-hash, the hash matches (the value
 * sweep_host prints: then the AVR computes bit-identical results to the host).
 * A group whose name starts with "base" is a baseline (the loads/stores around an operation); the
 * "net" column of every later group subtracts the mean of the latest baseline.
 * The program ends with cli; sleep, which simavr reports as cpu_Done.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"

enum { kMaxGroups = 64, kMaxName = 48 };
enum { kGpior0 = 0x3E, kGpior1 = 0x4A, kGpior2 = 0x4B }; /* data-space addresses */

typedef struct {
  char name[kMaxName];
  unsigned n;
  uint64_t min, max, sum;
  double baseline; /* mean of the baseline group in force, 0 for none */
} group_t;

typedef struct {
  group_t groups[kMaxGroups];
  int count;
  char pending[kMaxName];
  size_t pending_len;
  double baseline;
  uint64_t start;
  int in_sample;
  int errors;
  int self_check; /* -1 until the firmware reports */
  uint32_t hash;
  int hash_bytes; /* 4 once the hash is complete */
} bench_t;

static double mean(const group_t* g) { return g->n ? (double)g->sum / g->n : 0.0; }
static int is_baseline(const group_t* g) { return strncmp(g->name, "base", 4) == 0; }

static void close_group(bench_t* b) {
  if (b->count > 0 && is_baseline(&b->groups[b->count - 1])) {
    b->baseline = mean(&b->groups[b->count - 1]);
  }
}

static void on_name(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  bench_t* b = (bench_t*)param;
  (void)avr;
  (void)addr;
  if (v != 0) {
    if (b->pending_len + 1 < kMaxName) b->pending[b->pending_len++] = (char)v;
    return;
  }
  close_group(b);
  if (b->count == kMaxGroups) {
    b->errors++;
    return;
  }
  group_t* g = &b->groups[b->count++];
  memset(g, 0, sizeof *g);
  memcpy(g->name, b->pending, b->pending_len);
  g->min = UINT64_MAX;
  g->baseline = b->baseline;
  b->pending_len = 0;
}

static void on_marker(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  bench_t* b = (bench_t*)param;
  (void)addr;
  if (v == 1) {
    b->start = avr->cycle;
    b->in_sample = 1;
  } else if (v == 2 && b->in_sample && b->count > 0) {
    const uint64_t c = avr->cycle - b->start;
    group_t* g = &b->groups[b->count - 1];
    g->n++;
    g->sum += c;
    if (c < g->min) g->min = c;
    if (c > g->max) g->max = c;
    b->in_sample = 0;
  } else {
    b->errors++;
  }
}

static void on_check(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  bench_t* b = (bench_t*)param;
  (void)avr;
  (void)addr;
  if (b->self_check < 0) {
    b->self_check = v;
  } else if (b->hash_bytes < 4) {
    b->hash |= (uint32_t)v << (8 * b->hash_bytes);
    b->hash_bytes++;
  } else {
    b->errors++;
  }
}

/* simavr's default sleep callback throttles to wall-clock time; we want full speed. */
static void no_sleep(avr_t* avr, avr_cycle_count_t how_long) {
  (void)avr;
  (void)how_long;
}

static void print_table(const bench_t* b) {
  printf("%-24s %4s %8s %8s %8s %8s\n", "operation", "n", "min", "mean", "max", "net");
  for (int i = 0; i < b->count; ++i) {
    const group_t* g = &b->groups[i];
    if (is_baseline(g)) {
      printf("%-24s %4u %8llu %8.1f %8llu %8s\n", g->name, g->n, (unsigned long long)g->min,
             mean(g), (unsigned long long)g->max, "-");
    } else {
      printf("%-24s %4u %8llu %8.1f %8llu %8.1f\n", g->name, g->n, (unsigned long long)g->min,
             mean(g), (unsigned long long)g->max, mean(g) - g->baseline);
    }
  }
}

static int write_json(const bench_t* b, const char* path) {
  FILE* f = fopen(path, "w");
  if (!f) {
    perror(path);
    return 1;
  }
  fprintf(f, "{\n  \"mcu\": \"atmega328p\",\n  \"f_cpu\": 16000000,\n  \"unit\": \"cycles\",\n");
  fprintf(f, "  \"self_check_mismatches\": %d,\n", b->self_check);
  if (b->hash_bytes == 4) fprintf(f, "  \"results_hash\": \"0x%08lx\",\n", (unsigned long)b->hash);
  fprintf(f, "  \"results\": [\n");
  for (int i = 0; i < b->count; ++i) {
    const group_t* g = &b->groups[i];
    fprintf(f,
            "    {\"name\": \"%s\", \"n\": %u, \"min\": %llu, \"mean\": %.1f, \"max\": %llu, "
            "\"baseline\": %.1f, \"net_mean\": %.1f}%s\n",
            g->name, g->n, (unsigned long long)g->min, mean(g), (unsigned long long)g->max,
            is_baseline(g) ? 0.0 : g->baseline, is_baseline(g) ? 0.0 : mean(g) - g->baseline,
            i + 1 < b->count ? "," : "");
  }
  fprintf(f, "  ]\n}\n");
  return fclose(f) == 0 ? 0 : 1;
}

int main(int argc, char** argv) {
  const char* elf = NULL;
  const char* json = NULL;
  const char* expect_hash = NULL;
  for (int i = 1; i < argc; ++i) {
    if (strcmp(argv[i], "--json") == 0 && i + 1 < argc) {
      json = argv[++i];
    } else if (strcmp(argv[i], "--expect-hash") == 0 && i + 1 < argc) {
      expect_hash = argv[++i];
    } else if (!elf) {
      elf = argv[i];
    } else {
      fprintf(stderr, "usage: %s FIRMWARE.elf [--json FILE] [--expect-hash 0xHHHHHHHH]\n",
              argv[0]);
      return 2;
    }
  }
  if (!elf) {
    fprintf(stderr, "usage: %s FIRMWARE.elf [--json FILE] [--expect-hash 0xHHHHHHHH]\n", argv[0]);
    return 2;
  }

  elf_firmware_t fw;
  memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf, &fw) != 0) {
    fprintf(stderr, "cannot read %s\n", elf);
    return 1;
  }
  avr_t* avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) {
    fprintf(stderr, "simavr has no atmega328p\n");
    return 1;
  }
  avr_init(avr);
  avr->frequency = 16000000;
  avr_load_firmware(avr, &fw);
  avr->sleep = no_sleep;

  static bench_t bench;
  bench.self_check = -1;
  avr_register_io_write(avr, kGpior0, on_marker, &bench);
  avr_register_io_write(avr, kGpior1, on_name, &bench);
  avr_register_io_write(avr, kGpior2, on_check, &bench);

  int state;
  do {
    state = avr_run(avr);
  } while (state != cpu_Done && state != cpu_Crashed);

  if (state == cpu_Crashed) {
    fprintf(stderr, "firmware crashed after %llu cycles\n", (unsigned long long)avr->cycle);
    return 1;
  }
  close_group(&bench);
  print_table(&bench);
  if (bench.self_check < 0) {
    printf("self-check: not reported\n");
  } else {
    printf("self-check (AVR assembly vs portable C): %s, %d mismatches\n",
           bench.self_check == 0 ? "pass" : "FAIL", bench.self_check);
  }
  int hash_ok = 1;
  if (bench.hash_bytes == 4) {
    printf("results hash (AVR): 0x%08lx", (unsigned long)bench.hash);
    if (expect_hash) {
      hash_ok = strtoul(expect_hash, NULL, 16) == bench.hash;
      printf(", host: %s -> %s", expect_hash, hash_ok ? "identical" : "DIFFERENT");
    }
    printf("\n");
  } else {
    printf("results hash: not reported\n");
    hash_ok = expect_hash == NULL;
  }
  if (bench.errors) fprintf(stderr, "warning: %d protocol errors\n", bench.errors);
  if (json && write_json(&bench, json) != 0) return 1;
  return (bench.errors || bench.self_check != 0 || !hash_ok) ? 1 : 0;
}
