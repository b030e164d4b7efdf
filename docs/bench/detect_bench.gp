# Re-draw with: gnuplot detect_bench.gp
set terminal pngcairo size 1400,900 noenhanced font 'sans,10'
set output "detect_bench.png"
set datafile separator ','
set title "detectors on a synthetic photo of datasets/scenes/default.yaml: time vs corner error (median of 3 runs)\nIntel(R) Xeon(R) Processor, 2 cores, build RelWithDebInfo, 2026-11-22 04:38 UTC"
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key outside right top
set xlabel 'median detection time (ms), photo decoding excluded'
set ylabel 'RMS corner error against the truth (camera px)'
plot \
  'detect_bench.csv' skip 2 using (strcol(1) eq "board 16x5" ? $3 : 1/0):9 with points pt 7 ps 1.4 lc 1 title "board 16x5", \
  '< grep "^board 16x5,.*,1$" detect_bench.csv | sort -t, -k3 -g' using 3:9 with lines lw 2 lc 1 notitle, \
  'detect_bench.csv' skip 2 using (strcol(1) eq "board 11x11" ? $3 : 1/0):9 with points pt 7 ps 1.4 lc 2 title "board 11x11", \
  '< grep "^board 11x11,.*,1$" detect_bench.csv | sort -t, -k3 -g' using 3:9 with lines lw 2 lc 2 notitle, \
  'detect_bench.csv' skip 2 using (strcol(1) eq "tags 12x3" ? $3 : 1/0):9 with points pt 7 ps 1.4 lc 3 title "tags 12x3", \
  '< grep "^tags 12x3,.*,1$" detect_bench.csv | sort -t, -k3 -g' using 3:9 with lines lw 2 lc 3 notitle, \
  'detect_bench.csv' skip 2 using 3:9:2 with labels offset 0.8,0.5 left font ',7' notitle

unset output
