# Sourced by the scripts that report a firmware's memory (.ci/targets.sh,
# tools/board_field_cost.sh).

# elf_figures ELF: prints "FLASH RAM", the bytes of the allocated sections
# stored in flash (PROGBITS) and of the statics in RAM (.data, .bss, .uninit)
elf_figures() {
    local flash=0 ram=0 name type addr off size es flg rest
    while read -r name type addr off size es flg rest; do
        [[ "$type" =~ ^(PROGBITS|NOBITS)$ && "$flg" == *A* ]] || continue
        [ "$type" = PROGBITS ] && flash=$((flash + 16#$size))
        case $name in .data | .bss | .uninit) ram=$((ram + 16#$size)) ;; esac
    done < <(readelf -SW "$1" | sed -n 's/^ *\[ *[0-9]*\] *//p')
    echo "$flash $ram"
}
