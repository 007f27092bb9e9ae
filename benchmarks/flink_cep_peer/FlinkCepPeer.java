/*  The Flink CEP peer of benchmarks/cep_peers.py: one pattern of P0-P5 over one event stream, in a
    local (mini cluster) Flink environment of parallelism 1, in its own JVM.

    java -cp flink-dist.jar:flink-cep.jar:CLASSES FlinkCepPeer EVENTS PATTERN MODE

    EVENTS holds one event a line, `KIND ID VALUE T` (KIND is a, b or c), read into memory first.
    PATTERN is P0..P5; MODE is `restart` (the first state skips past the last event of a match:
    `begin(a, skipPastLastEvent())`) or `each` (`noSkip()`: every partial match goes on).
    The stream is keyed by Id (`keyBy(Id)`: the shared variable I of the patterns), processed in
    arrival order (`inProcessingTime()`: the stream's times grow with its order).

    Prints one line of JSON: the detections (matches of the pattern), the process CPU seconds and
    the wall seconds of the job over the whole stream, and those of the same job over a stream of
    one event run just before it (the baseline: starting and stopping a job in the mini cluster),
    after a first such job that warms the JVM up, so that the in-memory cost of the events is
    job - baseline.
*/

import java.io.BufferedReader;
import java.io.FileReader;
import java.io.IOException;
import java.lang.management.ManagementFactory;
import java.util.ArrayList;
import java.util.List;
import java.util.Map;
import java.util.concurrent.atomic.AtomicLong;

import org.apache.flink.api.common.typeinfo.Types;
import org.apache.flink.cep.CEP;
import org.apache.flink.cep.PatternStream;
import org.apache.flink.cep.functions.PatternProcessFunction;
import org.apache.flink.cep.nfa.aftermatch.AfterMatchSkipStrategy;
import org.apache.flink.cep.pattern.Pattern;
import org.apache.flink.cep.pattern.conditions.IterativeCondition;
import org.apache.flink.cep.pattern.conditions.SimpleCondition;
import org.apache.flink.streaming.api.datastream.DataStream;
import org.apache.flink.streaming.api.datastream.KeyedStream;
import org.apache.flink.streaming.api.environment.StreamExecutionEnvironment;
import org.apache.flink.streaming.api.functions.sink.v2.DiscardingSink;
import org.apache.flink.util.Collector;

public final class FlinkCepPeer {

    /** One event: a Flink POJO (public fields, a public constructor without arguments). */
    public static final class Ev {
        public char kind;
        public int id;
        public int value;
        public long t;

        public Ev() {
        }

        public Ev(char kind, int id, int value, long t) {
            this.kind = kind;
            this.id = id;
            this.value = value;
            this.t = t;
        }
    }

    /** The stream, in memory in this JVM (the local environment runs the job in the same JVM). */
    static volatile Ev[] events;

    static final class Kind extends SimpleCondition<Ev> {
        private final char kind;

        Kind(char kind) {
            this.kind = kind;
        }

        @Override
        public boolean filter(Ev e) {
            return e.kind == kind;
        }
    }

    /** The matches of the current job (the CEP operator's context has no accumulators; the job
        runs in this JVM, so a counter of the class counts them). */
    static final AtomicLong MATCHES = new AtomicLong();

    /** Counts the matches and emits nothing. */
    static final class Count extends PatternProcessFunction<Ev, Long> {
        @Override
        public void processMatch(Map<String, List<Ev>> match, Context context, Collector<Long> out) {
            MATCHES.incrementAndGet();
        }
    }

    static AfterMatchSkipStrategy skip(String mode) {
        return mode.equals("restart") ? AfterMatchSkipStrategy.skipPastLastEvent() : AfterMatchSkipStrategy.noSkip();
    }

    /** The Flink CEP patterns of the pattern name (P4's disjunction is two patterns, counted apart). */
    static List<Pattern<Ev, ?>> patterns(String name, String mode) {
        List<Pattern<Ev, ?>> out = new ArrayList<>();
        AfterMatchSkipStrategy s = skip(mode);
        switch (name) {
            case "P0": // zzz(I): no event of the stream has that kind
                out.add(Pattern.<Ev>begin("z", s).where(new Kind('z')));
                break;
            case "P1": // a seq b seq c
                out.add(Pattern.<Ev>begin("a", s).where(new Kind('a'))
                        .followedBy("b").where(new Kind('b'))
                        .followedBy("c").where(new Kind('c')));
                break;
            case "P2": // a and b and c: three events of the three kinds, in any order
                out.add(Pattern.<Ev>begin("e1", s).where(new IterativeCondition<Ev>() {
                    @Override
                    public boolean filter(Ev e, Context<Ev> ctx) {
                        return e.kind == 'a' || e.kind == 'b' || e.kind == 'c';
                    }
                }).followedBy("e2").where(new IterativeCondition<Ev>() {
                    @Override
                    public boolean filter(Ev e, Context<Ev> ctx) throws Exception {
                        for (Ev first : ctx.getEventsForPattern("e1")) {
                            if (first.kind == e.kind) {
                                return false;
                            }
                        }
                        return true;
                    }
                }).followedBy("e3").where(new IterativeCondition<Ev>() {
                    @Override
                    public boolean filter(Ev e, Context<Ev> ctx) throws Exception {
                        for (Ev first : ctx.getEventsForPattern("e1")) {
                            if (first.kind == e.kind) {
                                return false;
                            }
                        }
                        for (Ev second : ctx.getEventsForPattern("e2")) {
                            if (second.kind == e.kind) {
                                return false;
                            }
                        }
                        return true;
                    }
                }));
                break;
            case "P3": // (a seq b) cnot c: no c between the a and the b
                out.add(Pattern.<Ev>begin("a", s).where(new Kind('a'))
                        .notFollowedBy("c").where(new Kind('c'))
                        .followedBy("b").where(new Kind('b')));
                break;
            case "P4": // (a seq b) or c: Flink CEP has no disjunction of sequences, so two patterns
                out.add(Pattern.<Ev>begin("a", s).where(new Kind('a')).followedBy("b").where(new Kind('b')));
                out.add(Pattern.<Ev>begin("c", s).where(new Kind('c')));
                break;
            case "P5": // a seq b where (Y < 11): the condition is the b state's
                out.add(Pattern.<Ev>begin("a", s).where(new Kind('a'))
                        .followedBy("b").where(new SimpleCondition<Ev>() {
                            @Override
                            public boolean filter(Ev e) {
                                return e.kind == 'b' && e.value < 11;
                            }
                        }));
                break;
            default:
                throw new IllegalArgumentException("unknown pattern " + name);
        }
        return out;
    }

    static double processCpu() {
        return ((com.sun.management.OperatingSystemMXBean) ManagementFactory.getOperatingSystemMXBean())
                .getProcessCpuTime() / 1e9;
    }

    /** Runs the job over the first n events; its detections, process CPU seconds, wall seconds. */
    static double[] runJob(String name, String mode, int n) throws Exception {
        StreamExecutionEnvironment env = StreamExecutionEnvironment.createLocalEnvironment(1);
        DataStream<Ev> stream = env.fromSequence(0, n - 1).map(i -> events[(int) (long) i]).returns(Ev.class);
        KeyedStream<Ev, Integer> keyed = stream.keyBy(e -> e.id, Types.INT);
        List<Pattern<Ev, ?>> list = patterns(name, mode);
        for (int k = 0; k < list.size(); k++) {
            PatternStream<Ev> matches = CEP.pattern(keyed, list.get(k)).inProcessingTime();
            matches.process(new Count(), Types.LONG).sinkTo(new DiscardingSink<>());
        }
        MATCHES.set(0);
        double cpu0 = processCpu();
        long wall0 = System.nanoTime();
        env.execute("flink-cep-peer " + name + " " + mode);
        double cpu = processCpu() - cpu0;
        double wall = (System.nanoTime() - wall0) / 1e9;
        long detections = MATCHES.getAndSet(0);
        return new double[] {detections, cpu, wall};
    }

    static Ev[] read(String path) throws IOException {
        List<Ev> list = new ArrayList<>();
        try (BufferedReader in = new BufferedReader(new FileReader(path))) {
            String line;
            while ((line = in.readLine()) != null) {
                if (line.isEmpty()) {
                    continue;
                }
                String[] f = line.split(" ");
                list.add(new Ev(f[0].charAt(0), Integer.parseInt(f[1]), Integer.parseInt(f[2]), Long.parseLong(f[3])));
            }
        }
        return list.toArray(new Ev[0]);
    }

    public static void main(String[] args) throws Exception {
        if (args.length != 3) {
            System.err.println("usage: FlinkCepPeer EVENTS PATTERN restart|each");
            System.exit(2);
        }
        events = read(args[0]);
        runJob(args[1], args[2], 1);                          // warm-up: the first job's code is compiled
        double[] baseline = runJob(args[1], args[2], 1);      // a warm job's start and stop
        double[] job = runJob(args[1], args[2], events.length);
        System.out.printf("{\"events\": %d, \"detections\": %d, \"job_cpu\": %.6f, \"job_wall\": %.6f, "
                + "\"baseline_cpu\": %.6f, \"baseline_wall\": %.6f}%n",
                events.length, (long) job[0], job[1], job[2], baseline[1], baseline[2]);
    }
}
