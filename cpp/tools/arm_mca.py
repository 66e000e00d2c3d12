#!/usr/bin/env python3
"""Throughput of the AArch64 SAD inner loops, estimated with llvm-mca (qemu cannot time code).

For each kernel, the hot loop is taken from the assembly the cross compiler makes of the
repository's source (the byte-comparison loop with the most comparisons per iteration) and handed
to llvm-mca for a CPU model; the result is byte comparisons per cycle:

  scalar        cpp/src/matching/sad_scalar.cpp as shipped (auto-vectorization off: the reference path)
  plain C++     a plain |a - b| sum loop, -O3 -mcpu=<the CPU>: the compiler's best for that CPU
  neon          cpp/src/matching/arm/sad_neon.cpp as shipped (AArch64 baseline, no -mcpu)
  neon-dotprod  cpp/src/matching/arm/sad_neon_dotprod.cpp as shipped (CPUs with the dot product only)

CPU models: LLVM has no Cortex-A72 or A76 model of its own. -mcpu=cortex-a72 (and cortex-a76)
select its Cortex-A57 model (A72 is the A57's successor: same pipes, 1 load + 2 vector pipes);
for the A76 we use -mcpu=neoverse-n1, the model of the Neoverse N1, which is the Cortex-A76
microarchitecture (2 load + 2 vector pipes), and show the A57 model's figure beside it.
Use the newest llvm-mca available (LLVM 14, Debian 12's `llvm`, lacks the N1 model: `apt-get
install llvm-19`). The loops are steady-state, L1-resident estimates: no cache misses, no
front-end stalls, the scheduler's own pipe choices.

    apt-get install g++-aarch64-linux-gnu llvm-19
    python3 cpp/tools/arm_mca.py            # Markdown table on stdout
    python3 cpp/tools/arm_mca.py --show-loops   # and the loops themselves
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CPP = os.path.join(ROOT, "cpp")
# The flags of a Release build of the core (cpp/CMakeLists.txt).
SHIPPED_FLAGS = ["-O3", "-DNDEBUG", "-std=c++17", "-ffp-contract=off", "-fno-fast-math"]

PLAIN_LOOP = r"""
#include <cstddef>
#include <cstdint>
#include <cstdlib>
std::uint32_t plain_sad(const std::uint8_t* a, const std::uint8_t* b, std::size_t n) {
    std::uint32_t sum = 0;
    for (std::size_t i = 0; i < n; ++i) sum += static_cast<std::uint32_t>(std::abs(int{a[i]} - int{b[i]}));
    return sum;
}
"""

# (column title, compiler -mcpu for the plain loop, llvm-mca -mcpu, CPU has the dot product)
CPUS = [
    ("Cortex-A72 (A57 model)", "cortex-a72", "cortex-a72", False),
    ("Cortex-A76 (Neoverse-N1 model)", "cortex-a76", "neoverse-n1", True),
    ("Cortex-A76 (A57 model)", "cortex-a76", "cortex-a76", True),
]

BRANCH = re.compile(r"^\s*(b\.\w+|b|bne|beq|bcc|bcs|bhi|bls|bgt|blt|bge|ble|cbnz|cbz|tbnz|tbz)\s+(?:[^,]+,\s*)*(\.L\w+)\s*$")
LABEL = re.compile(r"^(\.L\w+):")
INSTRUCTION = re.compile(r"^\s+([a-z][\w.]*)\s*(.*)$")


def newest_llvm_mca() -> str:
    found = [p for p in glob.glob("/usr/bin/llvm-mca-*") if re.search(r"-\d+$", p)]
    found.sort(key=lambda p: int(p.rsplit("-", 1)[1]))
    if found:
        return found[-1]
    path = shutil.which("llvm-mca")
    if not path:
        sys.exit("llvm-mca not found (Debian: apt-get install llvm-19)")
    return path


def compile_to_asm(compiler: str, source: str, flags: list[str], out_dir: str, name: str) -> str:
    out = os.path.join(out_dir, name + ".s")
    cmd = [compiler, *flags, "-I", os.path.join(CPP, "include"), "-I", os.path.join(CPP, "src"), "-S", source, "-o", out]
    subprocess.run(cmd, check=True)
    with open(out) as f:
        return f.read()


def compared_bytes(instructions: list[tuple[str, str]]) -> int:
    """Byte comparisons one pass of the loop makes (vector absolute differences, or byte loads / 2)."""
    total = 0
    for op, args in instructions:
        if op in ("uabd", "uaba") and ".16b" in args:
            total += 16
        elif op in ("uabd", "uaba") and ".8b" in args:
            total += 8
        elif op in ("uabdl", "uabdl2", "uabal", "uabal2"):
            total += 8
    if total == 0:  # a scalar loop: two byte loads per comparison
        total = sum(1 for op, _ in instructions if op == "ldrb") // 2
    return total


def hot_loop(asm: str) -> tuple[list[tuple[str, str]], list[str]]:
    """The backward-branch loop of the assembly with the most byte comparisons per iteration."""
    lines = asm.splitlines()
    label_at = {}
    for i, line in enumerate(lines):
        m = LABEL.match(line)
        if m:
            label_at[m.group(1)] = i
    best: tuple[int, list[tuple[str, str]], list[str]] = (0, [], [])
    for i, line in enumerate(lines):
        m = BRANCH.match(line)
        if not m or m.group(2) not in label_at or label_at[m.group(2)] >= i:
            continue
        body_lines, body = [], []
        for text in lines[label_at[m.group(2)] + 1 : i + 1]:
            im = INSTRUCTION.match(text)
            if im and not im.group(1).startswith("."):
                body.append((im.group(1), im.group(2)))
                body_lines.append(text.strip())
        # straight-line bodies only: an inner branch means another loop or a rarely taken path
        inner_branches = sum(1 for t in body_lines[:-1] if BRANCH.match("\t" + t))
        score = compared_bytes(body)
        if inner_branches == 0 and score > best[0]:
            best = (score, body, body_lines)
    if best[0] == 0:
        raise RuntimeError("no byte-comparison loop found")
    return best[1], best[2]


def cycles_per_iteration(mca: str, cpu: str, body_lines: list[str], out_dir: str) -> float:
    path = os.path.join(out_dir, "loop.s")
    with open(path, "w") as f:
        f.write("\n".join(body_lines) + "\n")
    iterations = 1000
    done = subprocess.run(
        [mca, "-mtriple=aarch64", f"-mcpu={cpu}", "-mattr=+dotprod", f"-iterations={iterations}", path],
        check=True, capture_output=True, text=True,
    )
    m = re.search(r"Total Cycles:\s+(\d+)", done.stdout)
    if not m:
        raise RuntimeError(done.stdout + done.stderr)
    return int(m.group(1)) / iterations


def has_model(mca: str, cpu: str, unit_prefix: str) -> bool:
    """Whether llvm-mca schedules `cpu` with its own model (its resources carry `unit_prefix`)."""
    with tempfile.NamedTemporaryFile("w", suffix=".s") as f:
        f.write("add x0, x0, 1\n")
        f.flush()
        done = subprocess.run([mca, "-mtriple=aarch64", f"-mcpu={cpu}", "-iterations=1", f.name],
                              capture_output=True, text=True)
    return unit_prefix in done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cxx", default="aarch64-linux-gnu-g++", help="AArch64 cross compiler")
    parser.add_argument("--llvm-mca", default=None, help="llvm-mca program (default: the newest installed)")
    parser.add_argument("--show-loops", action="store_true", help="print each analysed loop")
    args = parser.parse_args()
    mca = args.llvm_mca or newest_llvm_mca()
    version = subprocess.run([mca, "--version"], capture_output=True, text=True).stdout
    version = re.search(r"LLVM version ([\d.]+)", version)
    compiler_version = subprocess.run([args.cxx, "--version"], capture_output=True, text=True).stdout.splitlines()[0]

    with tempfile.TemporaryDirectory() as tmp:
        plain_src = os.path.join(tmp, "plain.cpp")
        with open(plain_src, "w") as f:
            f.write(PLAIN_LOOP)
        shipped = {
            "scalar": compile_to_asm(args.cxx, os.path.join(ROOT, "cpp/src/matching/sad_scalar.cpp"), SHIPPED_FLAGS, tmp, "scalar"),
            "neon": compile_to_asm(args.cxx, os.path.join(ROOT, "cpp/src/matching/arm/sad_neon.cpp"), SHIPPED_FLAGS, tmp, "neon"),
            "neon-dotprod": compile_to_asm(
                args.cxx, os.path.join(ROOT, "cpp/src/matching/arm/sad_neon_dotprod.cpp"), SHIPPED_FLAGS, tmp, "dotprod"
            ),
        }
        rows = ["scalar (as shipped)", "plain C++ loop, -O3 -mcpu=<CPU>", "neon (as shipped)", "neon-dotprod (as shipped)"]
        table: dict[str, list[str]] = {row: [] for row in rows}
        loops: dict[str, list[str]] = {}
        for title, gcc_cpu, mca_cpu, has_dot in CPUS:
            plain = compile_to_asm(args.cxx, plain_src, ["-O3", f"-mcpu={gcc_cpu}", "-std=c++17"], tmp, "plain_" + gcc_cpu)
            for row, asm in zip(rows, [shipped["scalar"], plain, shipped["neon"], shipped["neon-dotprod"]]):
                if row.startswith("neon-dotprod") and not has_dot:
                    table[row].append("— (no dot product)")
                    continue
                body, body_lines = hot_loop(asm)
                cycles = cycles_per_iteration(mca, mca_cpu, body_lines, tmp)
                per_cycle = compared_bytes(body) / cycles
                table[row].append(f"{per_cycle:.1f} ({compared_bytes(body)} B / {cycles:.2f} cycles)")
                loops[f"{row}, {title}"] = body_lines

    print(f"llvm-mca {version.group(1) if version else '?'} ({mca}); {compiler_version}")
    if not has_model(mca, "neoverse-n1", "N1Unit"):
        print("warning: this llvm-mca has no Neoverse-N1 model (its neoverse-n1 is the A57 model): install llvm-19")
    print("Byte comparisons per cycle of the hot loop (bytes per iteration / cycles per iteration):\n")
    print("| loop | " + " | ".join(title for title, *_ in CPUS) + " |")
    print("| --- | " + " | ".join("---" for _ in CPUS) + " |")
    for row in rows:
        print(f"| {row} | " + " | ".join(table[row]) + " |")
    if args.show_loops:
        for name, body_lines in loops.items():
            print(f"\n{name}:\n    " + "\n    ".join(body_lines))
    return 0


if __name__ == "__main__":
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `| head` ends it quietly
    sys.exit(main())
